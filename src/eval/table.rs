//! The numbers behind every chart: a table of typed columns, written and read as CSV.
//!
//! Each experiment declares its columns once ([`Column`]); every case returns rows of those columns,
//! and the merged table (one CSV per experiment) is what charts and summaries are drawn from. A
//! column is either *computed* (the same on every run: errors, areas, iteration counts) or *timed*
//! (wall-clock figures that differ between runs and machines); only computed columns must agree
//! between a one-shot run and the same cases run one by one and merged.

use std::path::Path;

use super::EvalError;

/// Whether a column's values are reproducible or measured wall-clock time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Reproducible: the same inputs give the same value, bit for bit.
    Computed,
    /// Wall-clock time (or derived from it): varies from run to run.
    Timed,
}

/// One column: its CSV header, unit and kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Column {
    /// CSV header (snake case).
    pub name: &'static str,
    /// Unit (`""` for dimensionless or text).
    pub unit: &'static str,
    /// Reproducible or timed.
    pub kind: Kind,
}

/// A computed column.
pub const fn computed(name: &'static str, unit: &'static str) -> Column {
    Column { name, unit, kind: Kind::Computed }
}

/// A timed column.
pub const fn timed(name: &'static str, unit: &'static str) -> Column {
    Column { name, unit, kind: Kind::Timed }
}

/// One cell.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// A number (NaN stands for "not measured", written as an empty cell).
    Num(f64),
    /// Text (method names, outcomes, messages).
    Text(String),
}

impl Value {
    /// The number, or NaN for text and empty cells.
    pub fn num(&self) -> f64 {
        match self {
            Value::Num(x) => *x,
            Value::Text(_) => f64::NAN,
        }
    }

    /// The text (numbers formatted as in the CSV).
    pub fn text(&self) -> String {
        match self {
            Value::Num(x) => format_number(*x),
            Value::Text(s) => s.clone(),
        }
    }
}

impl From<f64> for Value {
    fn from(x: f64) -> Self {
        Value::Num(x)
    }
}

impl From<&str> for Value {
    fn from(s: &str) -> Self {
        Value::Text(s.to_string())
    }
}

impl From<String> for Value {
    fn from(s: String) -> Self {
        Value::Text(s)
    }
}

/// Shortest text that reads back as the same `f64` (empty for NaN).
pub fn format_number(x: f64) -> String {
    if x.is_nan() { String::new() } else { format!("{x:?}") }
}

/// Rows of values under declared columns.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// The columns, in order.
    pub columns: &'static [Column],
    /// The rows; each has one value per column.
    pub rows: Vec<Vec<Value>>,
}

impl Table {
    /// An empty table.
    pub fn new(columns: &'static [Column]) -> Self {
        Self { columns, rows: Vec::new() }
    }

    /// Append a row given as (column name, value) pairs; columns not named are left empty (NaN).
    /// Naming a column the table does not have is a programming error, reported as such.
    pub fn push(&mut self, cells: Vec<(&str, Value)>) -> Result<(), EvalError> {
        let mut row = vec![Value::Num(f64::NAN); self.columns.len()];
        for (name, value) in cells {
            let i = self.index(name)?;
            row[i] = value;
        }
        self.rows.push(row);
        Ok(())
    }

    /// Index of a column.
    pub fn index(&self, name: &str) -> Result<usize, EvalError> {
        self.columns
            .iter()
            .position(|c| c.name == name)
            .ok_or_else(|| EvalError::Data(format!("no column `{name}` in this table")))
    }

    /// The value of column `name` in `row`.
    pub fn get(&self, row: &[Value], name: &str) -> Result<Value, EvalError> {
        Ok(row[self.index(name)?].clone())
    }

    /// Rows whose column `name` has the text `value`.
    pub fn filter<'a>(&'a self, name: &str, value: &'a str) -> Result<impl Iterator<Item = &'a Vec<Value>>, EvalError> {
        let i = self.index(name)?;
        Ok(self.rows.iter().filter(move |r| matches!(&r[i], Value::Text(t) if t == value)))
    }

    /// Append another table's rows (same columns).
    pub fn extend(&mut self, other: Table) -> Result<(), EvalError> {
        if other.columns != self.columns {
            return Err(EvalError::Data("tables with different columns cannot be merged".into()));
        }
        self.rows.extend(other.rows);
        Ok(())
    }

    /// Write as CSV (header row of column names, then the rows), atomically: a temporary file renamed
    /// into place, so a reader never sees half a table.
    pub fn write_csv(&self, path: &Path) -> Result<(), EvalError> {
        let mut w = csv::Writer::from_writer(Vec::new());
        let io = |e: csv::Error| EvalError::Io { path: path.to_path_buf(), reason: e.to_string() };
        w.write_record(self.columns.iter().map(|c| c.name)).map_err(io)?;
        for row in &self.rows {
            w.write_record(row.iter().map(Value::text)).map_err(io)?;
        }
        let bytes = w.into_inner().map_err(|e| EvalError::Io { path: path.to_path_buf(), reason: e.to_string() })?;
        super::write_atomically(path, &bytes)
    }

    /// Read a CSV written by [`Table::write_csv`] for these columns. Cells that parse as numbers become
    /// numbers, empty cells NaN, others text.
    pub fn read_csv(path: &Path, columns: &'static [Column]) -> Result<Self, EvalError> {
        let bad = |reason: String| EvalError::Io { path: path.to_path_buf(), reason };
        let mut r = csv::Reader::from_path(path).map_err(|e| bad(e.to_string()))?;
        let header: Vec<String> = r.headers().map_err(|e| bad(e.to_string()))?.iter().map(str::to_string).collect();
        let expected: Vec<&str> = columns.iter().map(|c| c.name).collect();
        if header != expected {
            return Err(bad(format!("columns {header:?}, expected {expected:?}")));
        }
        let mut table = Table::new(columns);
        for record in r.records() {
            let record = record.map_err(|e| bad(e.to_string()))?;
            table.rows.push(record.iter().map(parse_cell).collect());
        }
        Ok(table)
    }
}

fn parse_cell(s: &str) -> Value {
    if s.is_empty() {
        return Value::Num(f64::NAN);
    }
    match s.parse::<f64>() {
        Ok(x) => Value::Num(x),
        Err(_) => Value::Text(s.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const COLUMNS: &[Column] = &[computed("method", ""), computed("error", ""), timed("seconds", "s")];

    #[test]
    fn csv_round_trip_keeps_every_bit_text_and_missing_values() {
        let mut t = Table::new(COLUMNS);
        t.push(vec![("method", "mwts".into()), ("error", (0.1 + 0.2).into()), ("seconds", 1e-7.into())]).unwrap();
        t.push(vec![("method", "a, \"quoted\" name".into()), ("error", (1.0f64 / 3.0).into())]).unwrap();
        let dir = std::env::temp_dir().join(format!("shellwarp-table-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("t.csv");
        t.write_csv(&path).unwrap();
        let back = Table::read_csv(&path, COLUMNS).unwrap();
        assert_eq!(back.rows.len(), 2);
        assert_eq!(back.rows[0][0], Value::Text("mwts".into()));
        assert_eq!(back.rows[0][1].num().to_bits(), (0.1f64 + 0.2).to_bits());
        assert_eq!(back.rows[1][0], Value::Text("a, \"quoted\" name".into()));
        assert!(back.rows[1][2].num().is_nan(), "an unset cell reads back as missing");
        assert!(t.push(vec![("nope", 1.0.into())]).is_err());
        const OTHER: &[Column] = &[computed("method", "")];
        assert!(Table::read_csv(&path, OTHER).is_err(), "a CSV with other columns is refused");
        std::fs::remove_dir_all(dir).unwrap();
    }
}
