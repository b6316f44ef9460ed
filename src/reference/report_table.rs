//! The report's tables: what `photondiff report --table` reads, what the benchmarks write beside
//! their pages, and the Markdown they print for README.

use serde::{Deserialize, Serialize};
use std::path::Path;

/// A table (the timing table, say); its JSON form is what `photondiff report --table` reads:
/// `{"title": "...", "columns": ["..."], "rows": [["text", 1.5, ...]], "notes": ["..."]}`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Table {
    /// Its heading.
    pub title: String,
    /// Column headings.
    pub columns: Vec<String>,
    /// Rows of strings or numbers, as many cells as columns.
    pub rows: Vec<Vec<serde_json::Value>>,
    /// Lines of text under the table.
    #[serde(default)]
    pub notes: Vec<String>,
}

/// A cell as text: strings as they are, numbers as JSON writes them, null as nothing.
pub fn cell_text(v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::String(s) => s.clone(),
        serde_json::Value::Null => String::new(),
        other => other.to_string(),
    }
}

impl Table {
    /// Reads a table written as JSON, checking that every row has one cell per column.
    pub fn read(path: &Path) -> Result<Table, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
        let table: Table = serde_json::from_str(&text)
            .map_err(|e| format!("{}: not a report table: {e}", path.display()))?;
        if let Some((k, row)) = table
            .rows
            .iter()
            .enumerate()
            .find(|(_, r)| r.len() != table.columns.len())
        {
            return Err(format!(
                "{}: row {} has {} cells but there are {} columns",
                path.display(),
                k + 1,
                row.len(),
                table.columns.len()
            ));
        }
        Ok(table)
    }

    /// Writes the table as JSON (what [`Table::read`] reads).
    pub fn write(&self, path: &Path) -> Result<(), String> {
        let text = serde_json::to_string_pretty(self).map_err(|e| e.to_string())?;
        std::fs::write(path, text).map_err(|e| format!("{}: cannot write: {e}", path.display()))
    }

    /// The table as Markdown (header, separator, rows), as README records it.
    pub fn markdown(&self) -> String {
        let line = |cells: Vec<String>| format!("| {} |\n", cells.join(" | "));
        let mut out = line(self.columns.clone());
        out += &format!("|{}\n", "---|".repeat(self.columns.len()));
        for row in &self.rows {
            out += &line(row.iter().map(cell_text).collect());
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn table() -> Table {
        Table {
            title: "t".into(),
            columns: vec!["method".into(), "s".into(), "note".into()],
            rows: vec![vec![json!("a"), json!(0.5), json!(null)]],
            notes: vec!["n".into()],
        }
    }

    #[test]
    fn markdown_has_a_header_a_separator_and_one_line_per_row() {
        assert_eq!(
            table().markdown(),
            "| method | s | note |\n|---|---|---|\n| a | 0.5 |  |\n"
        );
    }

    #[test]
    fn written_tables_read_back_and_ragged_rows_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.json");
        table().write(&path).unwrap();
        let back = Table::read(&path).unwrap();
        assert_eq!(back.rows, table().rows);
        assert_eq!(back.columns, table().columns);
        let mut ragged = table();
        ragged.rows.push(vec![json!("b")]);
        ragged.write(&path).unwrap();
        assert_eq!(
            Table::read(&path).unwrap_err(),
            format!(
                "{}: row 2 has 1 cells but there are 3 columns",
                path.display()
            )
        );
    }
}
