//! Reading the tables [`crate::parquet_io`] writes: the schema checked against the expected columns, every
//! fixed-shape list checked against its shape, and a panic inside the parquet crate (a damaged file it does not
//! expect) turned into an error naming the file.

use crate::error::DatasetError;
use crate::parquet_io::{batch_rows, column_type, perr, rep_pattern, Data, Kind};
use parquet::column::reader::ColumnReader;
use parquet::data_type::{ByteArray, FixedLenByteArray};
use parquet::file::reader::{FileReader, SerializedFileReader};
use parquet::schema::types::Type;
use std::collections::BTreeMap;
use std::path::Path;

/// A table read back: its columns in the expected order and the footer's key-value metadata.
#[derive(Clone, Debug)]
pub struct Table {
    pub rows: usize,
    pub columns: Vec<Data>,
    pub metadata: BTreeMap<String, String>,
}

/// Reads only the footer's key-value metadata and row count (`None` values are dropped).
pub fn read_footer(path: &Path) -> Result<(usize, BTreeMap<String, String>), DatasetError> {
    guard(path, || {
        let file = std::fs::File::open(path).map_err(|e| DatasetError::io(path, e))?;
        let reader = SerializedFileReader::new(file).map_err(perr(path))?;
        let meta = reader.metadata().file_metadata();
        Ok((
            usize::try_from(meta.num_rows()).unwrap_or(0),
            footer_kv(meta),
        ))
    })
}

fn footer_kv(meta: &parquet::file::metadata::FileMetaData) -> BTreeMap<String, String> {
    meta.key_value_metadata()
        .map(|kv| {
            kv.iter()
                .filter_map(|k| Some((k.key.clone(), k.value.clone()?)))
                .collect()
        })
        .unwrap_or_default()
}

/// Runs a read, turning a panic inside the parquet crate (a damaged file it does not expect) into an error.
fn guard<T>(path: &Path, f: impl FnOnce() -> Result<T, DatasetError>) -> Result<T, DatasetError> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(_) => Err(DatasetError::parquet(
            path,
            "damaged file: the parquet reader failed on it",
        )),
    }
}

fn describe(t: &Type) -> String {
    let mut out = Vec::new();
    parquet::schema::printer::print_schema(&mut out, t);
    String::from_utf8_lossy(&out)
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

/// The differences between a file's columns and the expected ones, one line per column.
pub fn schema_differences(file_root: &Type, expected: &[(String, Kind)]) -> Vec<String> {
    let fields = file_root.get_fields();
    let mut out = Vec::new();
    for (name, kind) in expected {
        match fields.iter().find(|f| f.name() == name) {
            None => out.push(format!("column `{name}`: missing")),
            Some(f) => match column_type(name, kind) {
                Ok(want) if **f == want => {}
                Ok(want) => out.push(format!(
                    "column `{name}`: expected `{}`, found `{}`",
                    describe(&want),
                    describe(f)
                )),
                Err(e) => out.push(format!("column `{name}`: {e}")),
            },
        }
    }
    for f in fields {
        if !expected.iter().any(|(n, _)| n == f.name()) {
            out.push(format!("column `{}`: not part of the format", f.name()));
        }
    }
    if out.is_empty()
        && fields
            .iter()
            .map(|f| f.name())
            .ne(expected.iter().map(|(n, _)| n.as_str()))
    {
        out.push("columns are in another order than the format's".into());
    }
    out
}

enum Raw {
    F32(Vec<f32>),
    F64(Vec<f64>),
    I64(Vec<i64>),
    Bool(Vec<bool>),
    Bytes(Vec<ByteArray>),
    Fixed(Vec<FixedLenByteArray>),
}

/// Reads `path`, checking that its schema is exactly `expected` and every fixed-shape list has its shape.
pub fn read_table(path: &Path, expected: &[(String, Kind)]) -> Result<Table, DatasetError> {
    guard(path, || read_table_inner(path, expected))
}

fn read_table_inner(path: &Path, expected: &[(String, Kind)]) -> Result<Table, DatasetError> {
    let err = perr(path);
    let file = std::fs::File::open(path).map_err(|e| DatasetError::io(path, e))?;
    let reader = SerializedFileReader::new(file).map_err(&err)?;
    let meta = reader.metadata();
    let diffs = schema_differences(meta.file_metadata().schema(), expected);
    if !diffs.is_empty() {
        return Err(DatasetError::parquet(
            path,
            format!("schema: {}", diffs.join("; ")),
        ));
    }
    let rows = usize::try_from(meta.file_metadata().num_rows())
        .map_err(|_| DatasetError::parquet(path, "negative row count"))?;
    let mut columns: Vec<Data> = expected.iter().map(|(_, k)| empty(k)).collect();
    let mut seen = 0usize;
    for g in 0..reader.num_row_groups() {
        let rg = reader.get_row_group(g).map_err(&err)?;
        let group_rows = usize::try_from(rg.metadata().num_rows()).map_err(|_| {
            DatasetError::parquet(path, format!("row group {g}: negative row count"))
        })?;
        seen += group_rows;
        for (i, (name, kind)) in expected.iter().enumerate() {
            let per_row = match kind {
                Kind::ListF32(s) | Kind::ListF64(s) | Kind::ListF16(s) => s.iter().product(),
                _ => 1,
            };
            let batch = batch_rows(per_row);
            let mut col = rg.get_column_reader(i).map_err(&err)?;
            let mut done = 0usize;
            // Whole records, batch by batch: each batch decoded (and its lists checked) on its own.
            while done < group_rows {
                let want = batch.min(group_rows - done);
                let (mut def, mut rep) = (Vec::new(), Vec::new());
                macro_rules! read {
                    ($r:expr, $variant:ident) => {{
                        let mut v = Vec::new();
                        let (n, _, _) = $r
                            .read_records(want, Some(&mut def), Some(&mut rep), &mut v)
                            .map_err(&err)?;
                        (n, Raw::$variant(v))
                    }};
                }
                let (n, raw) = match &mut col {
                    ColumnReader::FloatColumnReader(r) => read!(r, F32),
                    ColumnReader::DoubleColumnReader(r) => read!(r, F64),
                    ColumnReader::Int64ColumnReader(r) => read!(r, I64),
                    ColumnReader::BoolColumnReader(r) => read!(r, Bool),
                    ColumnReader::ByteArrayColumnReader(r) => read!(r, Bytes),
                    ColumnReader::FixedLenByteArrayColumnReader(r) => read!(r, Fixed),
                    ColumnReader::Int32ColumnReader(_) | ColumnReader::Int96ColumnReader(_) => {
                        return Err(DatasetError::parquet(
                            path,
                            format!("column `{name}`: unexpected type"),
                        ))
                    }
                };
                if n == 0 {
                    return Err(DatasetError::parquet(
                        path,
                        format!("column `{name}`: {done} rows, row group {g} says {group_rows}"),
                    ));
                }
                let at = |m: String| DatasetError::parquet(path, format!("column `{name}`: {m}"));
                let first = seen - group_rows + done;
                let data = decode(kind, Some(raw), &def, &rep, n, first).map_err(at)?;
                columns[i].append(data).map_err(at)?;
                done += n;
            }
        }
    }
    if seen != rows {
        return Err(DatasetError::parquet(
            path,
            format!("row groups hold {seen} rows, the footer says {rows}"),
        ));
    }
    Ok(Table {
        rows,
        columns,
        metadata: footer_kv(meta.file_metadata()),
    })
}

fn utf8(b: &ByteArray) -> Result<String, String> {
    b.as_utf8().map(str::to_string).map_err(|e| e.to_string())
}

fn optional<T: Clone>(values: &[T], def: &[i16], rows: usize) -> Result<Vec<Option<T>>, String> {
    if def.len() != rows {
        return Err(format!("{} definition levels for {rows} rows", def.len()));
    }
    let mut it = values.iter();
    def.iter()
        .map(|&d| {
            if d == 1 {
                it.next()
                    .cloned()
                    .map(Some)
                    .ok_or_else(|| "too few values".to_string())
            } else {
                Ok(None)
            }
        })
        .collect()
}

/// Checks that every row of a fixed-shape column has the shape's nesting and value count.
fn check_fixed(
    shape: &[usize],
    n_values: usize,
    def: &[i16],
    rep: &[i16],
    rows: usize,
    first: usize,
) -> Result<(), String> {
    let n: usize = shape.iter().product();
    let pattern = rep_pattern(shape);
    let depth = shape.len() as i16;
    let ok = n_values == n * rows
        && def.len() == n * rows
        && def.iter().all(|&d| d == depth)
        && rep.iter().zip(pattern.iter().cycle()).all(|(a, b)| a == b);
    if ok {
        return Ok(());
    }
    // Name the first row whose list is not of the shape.
    let starts: Vec<usize> = rep
        .iter()
        .enumerate()
        .filter(|(_, &r)| r == 0)
        .map(|(i, _)| i)
        .collect();
    for (row, &s) in starts.iter().enumerate() {
        let end = starts.get(row + 1).copied().unwrap_or(rep.len());
        let len = def[s.min(def.len())..end.min(def.len())]
            .iter()
            .filter(|&&d| d == depth)
            .count();
        if len != n || rep[s..end] != pattern[..] {
            return Err(format!(
                "row {}: {len} values, expected a list of shape {shape:?} ({n} values)",
                first + row
            ));
        }
    }
    Err(format!("{} rows of lists, expected {rows}", starts.len()))
}

fn decode(
    kind: &Kind,
    raw: Option<Raw>,
    def: &[i16],
    rep: &[i16],
    rows: usize,
    first: usize,
) -> Result<Data, String> {
    let count = |n: usize| {
        if n == rows {
            Ok(())
        } else {
            Err(format!("{n} values for {rows} rows"))
        }
    };
    Ok(match (kind, raw) {
        (_, None) if rows == 0 => empty(kind),
        (Kind::F32, Some(Raw::F32(v))) => {
            count(v.len())?;
            Data::F32(v)
        }
        (Kind::F64, Some(Raw::F64(v))) => {
            count(v.len())?;
            Data::F64(v)
        }
        (Kind::I64, Some(Raw::I64(v))) => {
            count(v.len())?;
            Data::I64(v)
        }
        (Kind::U64, Some(Raw::I64(v))) => {
            count(v.len())?;
            Data::U64(v.into_iter().map(|x| x as u64).collect())
        }
        (Kind::Bool, Some(Raw::Bool(v))) => {
            count(v.len())?;
            Data::Bool(v)
        }
        (Kind::Str, Some(Raw::Bytes(v))) => {
            count(v.len())?;
            Data::Str(v.iter().map(utf8).collect::<Result<_, _>>()?)
        }
        (Kind::OptStr, Some(Raw::Bytes(v))) => Data::OptStr(
            optional(&v, def, rows)?
                .into_iter()
                .map(|o| o.map(|b| utf8(&b)).transpose())
                .collect::<Result<_, _>>()?,
        ),
        (Kind::OptF64, Some(Raw::F64(v))) => Data::OptF64(optional(&v, def, rows)?),
        (Kind::OptU64, Some(Raw::I64(v))) => Data::OptU64(
            optional(&v, def, rows)?
                .into_iter()
                .map(|o| o.map(|x| x as u64))
                .collect(),
        ),
        (Kind::OptBool, Some(Raw::Bool(v))) => Data::OptBool(optional(&v, def, rows)?),
        (Kind::ListStr, Some(Raw::Bytes(v))) => {
            let mut out: Vec<Vec<String>> = Vec::with_capacity(rows);
            let mut it = v.iter();
            for (&d, &r) in def.iter().zip(rep) {
                if r == 0 {
                    out.push(Vec::new());
                }
                if d == 1 {
                    let s = it.next().ok_or("too few values")?;
                    out.last_mut()
                        .ok_or("a list continues before it starts")?
                        .push(utf8(s)?);
                }
            }
            count(out.len())?;
            Data::ListStr(out)
        }
        (Kind::ListF32(shape), Some(Raw::F32(v))) => {
            check_fixed(shape, v.len(), def, rep, rows, first)?;
            Data::ListF32(v)
        }
        (Kind::ListF64(shape), Some(Raw::F64(v))) => {
            check_fixed(shape, v.len(), def, rep, rows, first)?;
            Data::ListF64(v)
        }
        (Kind::ListF16(shape), Some(Raw::Fixed(v))) => {
            check_fixed(shape, v.len(), def, rep, rows, first)?;
            Data::ListF16(
                v.iter()
                    .map(|b| match b.data() {
                        [lo, hi] => Ok(u16::from_le_bytes([*lo, *hi])),
                        _ => Err("a float16 value that is not 2 bytes".to_string()),
                    })
                    .collect::<Result<_, _>>()?,
            )
        }
        _ => return Err("values of another type than the schema's".into()),
    })
}

fn empty(kind: &Kind) -> Data {
    match kind {
        Kind::F32 => Data::F32(Vec::new()),
        Kind::F64 => Data::F64(Vec::new()),
        Kind::I64 => Data::I64(Vec::new()),
        Kind::U64 => Data::U64(Vec::new()),
        Kind::Bool => Data::Bool(Vec::new()),
        Kind::Str => Data::Str(Vec::new()),
        Kind::OptStr => Data::OptStr(Vec::new()),
        Kind::OptF64 => Data::OptF64(Vec::new()),
        Kind::OptU64 => Data::OptU64(Vec::new()),
        Kind::OptBool => Data::OptBool(Vec::new()),
        Kind::ListStr => Data::ListStr(Vec::new()),
        Kind::ListF32(_) => Data::ListF32(Vec::new()),
        Kind::ListF64(_) => Data::ListF64(Vec::new()),
        Kind::ListF16(_) => Data::ListF16(Vec::new()),
    }
}
