//! Every option of every command is documented: each long option that a command's `--help`
//! lists appears in README.md as code (`` `--option``, or `` `-o, --option`` beside its short
//! form), so an option added without a word in the README fails here.

use std::process::Command;

const EXE: &str = env!("CARGO_BIN_EXE_photondiff");

fn help(args: &[&str]) -> String {
    let out = Command::new(EXE).args(args).arg("--help").output().unwrap();
    assert!(out.status.success(), "{args:?} --help");
    String::from_utf8(out.stdout).unwrap()
}

/// The long options (`--name`) named in a help text, each once.
fn long_options(text: &str) -> Vec<String> {
    let mut found: Vec<String> = text
        .split(|c: char| !(c.is_ascii_alphanumeric() || c == '-'))
        .filter(|w| w.starts_with("--") && w.len() > 2 && w.as_bytes()[2].is_ascii_lowercase())
        .map(str::to_string)
        .collect();
    found.sort();
    found.dedup();
    found
}

/// Whether `text` shows `option` as code: right after a backtick, or after a short form
/// (`` `-o, --option``), and not as the start of a longer name.
fn documented(text: &str, option: &str) -> bool {
    text.match_indices(option).any(|(at, _)| {
        let after = text[at + option.len()..].chars().next();
        let whole = !after.is_some_and(|c| c.is_ascii_alphanumeric() || c == '-');
        let before = &text[..at];
        let code = before.ends_with('`')
            || (before.ends_with(", ") && before.rfind('`').is_some_and(|tick| at - tick <= 5));
        whole && code
    })
}

#[test]
fn every_commands_options_are_in_the_readme() {
    let readme =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md")).unwrap();
    // The commands, from the top-level help's list.
    let top = help(&[]);
    let commands: Vec<&str> = top
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|&c| c != "help")
        .collect();
    assert_eq!(
        commands,
        [
            "render",
            "reference",
            "merge",
            "photons",
            "compare",
            "report",
            "info"
        ]
    );
    let mut missing = Vec::new();
    let mut checked = 0;
    for command in commands {
        for option in long_options(&help(&[command])) {
            checked += 1;
            if !documented(&readme, &option) {
                missing.push(format!("{command} {option}"));
            }
        }
    }
    assert!(missing.is_empty(), "not in README.md: {missing:?}");
    // render alone has more than thirty options: the help was read, not an empty text.
    assert!(checked > 60, "{checked} options checked");
}

/// Every estimator the command line takes is described in the README's `--estimator` row (as
/// code, `` `name` ``): clap lists a new one in `--help` by itself, the README does not.
#[test]
fn every_estimator_is_in_the_readmes_estimator_row() {
    use clap::ValueEnum;
    let readme =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md")).unwrap();
    let row = readme
        .lines()
        .find(|l| l.starts_with("| `--estimator E` |"))
        .expect("README has the render options' --estimator row");
    let mut names = Vec::new();
    for kind in photondiff::estimate::EstimatorKind::value_variants() {
        let name = kind.to_possible_value().unwrap().get_name().to_string();
        assert!(
            row.contains(&format!("`{name}`")),
            "`{name}` is not described in README's --estimator row"
        );
        names.push(name);
    }
    assert!(names.len() >= 7, "{names:?}");
}
