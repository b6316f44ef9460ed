//! Messages on standard error that never end the run. `eprintln!` panics when standard error
//! cannot be written (its reader gone, `2>/dev/full`, a terminal hung up): a render whose log
//! pipe closed ended with status 101 before writing its image, and a hang-up (which stops a
//! render as Ctrl-C does, keeping its passes) lost them. A message that cannot be written is
//! dropped; the run goes on.

use std::io::Write;

/// Writes `text` to standard error, ignoring a failure.
pub fn write(text: std::fmt::Arguments) {
    let _ = std::io::stderr().write_fmt(text);
}

/// `eprintln!` that drops what cannot be written instead of panicking ([`write()`]).
#[macro_export]
macro_rules! stderr_line {
    ($($arg:tt)*) => {
        $crate::util::stderr::write(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// `eprint!` that drops what cannot be written instead of panicking ([`write()`]).
#[macro_export]
macro_rules! stderr_text {
    ($($arg:tt)*) => {
        $crate::util::stderr::write(format_args!($($arg)*))
    };
}
