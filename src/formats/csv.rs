//! CSV text for saved values and reports, written by the `csv` crate (`::csv` below, the crate,
//! not this module).

/// CSV text of `records`, the header first, written by the `csv` crate: RFC 4180 quoting (a
/// field is quoted only when it holds a comma, a double quote or a line break, and its quotes
/// are doubled), `\n` after each record. Numbers are formatted by the caller, so that each file
/// keeps its own precision. A record of no field becomes `""` (one empty field), as the crate
/// writes it.
pub fn text<R, F>(records: impl IntoIterator<Item = R>) -> String
where
    R: IntoIterator<Item = F>,
    F: AsRef<[u8]>,
{
    // Flexible: the records' lengths are the caller's (they agree in every file written here).
    let mut w = ::csv::WriterBuilder::new().flexible(true).from_writer(Vec::new());
    for record in records {
        // Writing into a Vec has no I/O to fail, and a flexible writer no length to refuse.
        w.write_record(record).expect("CSV into memory");
    }
    let bytes = w.into_inner().expect("CSV into memory");
    String::from_utf8(bytes).expect("UTF-8 fields give UTF-8 CSV")
}
