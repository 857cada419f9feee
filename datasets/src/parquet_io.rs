//! Parquet tables with the parquet crate's low-level column writers and readers (no Arrow): flat columns,
//! nullable ones, lists of strings, and fixed-shape numeric features as standard 3-level LIST columns
//! (`required group name (LIST) { repeated group list { required <type> element; } }`, nested once more per extra
//! dimension, so a `[a, b]` feature reads as a list of `a` lists of `b`), float16 as `FIXED_LEN_BYTE_ARRAY(2)`
//! with the `FLOAT16` logical type. Files are built in memory and written atomically by the caller; reading is in
//! [`crate::parquet_read`].

use crate::error::DatasetError;
use bytes::Bytes;
use parquet::basic::{Compression, LogicalType, Repetition, Type as Physical};
use parquet::data_type::{
    BoolType, ByteArray, ByteArrayType, DoubleType, FixedLenByteArray, FixedLenByteArrayType,
    FloatType, Int64Type,
};
use parquet::errors::ParquetError;
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;
use parquet::file::writer::{SerializedColumnWriter, SerializedFileWriter};
use parquet::schema::types::Type;
use std::path::Path;
use std::sync::Arc;

/// A column's type.
#[derive(Clone, Debug, PartialEq)]
pub enum Kind {
    F32,
    F64,
    I64,
    /// `INT64` with the unsigned 64-bit integer logical type.
    U64,
    Bool,
    Str,
    OptStr,
    OptF64,
    OptU64,
    OptBool,
    ListStr,
    /// A fixed-shape float32 feature (row-major values, `shape.len()` nested lists).
    ListF32(Vec<usize>),
    /// A fixed-shape float64 feature (row-major values, `shape.len()` nested lists).
    ListF64(Vec<usize>),
    /// A fixed-shape float16 feature, values as IEEE half bits.
    ListF16(Vec<usize>),
}

/// A column's values, one entry per row (per value for fixed-shape features).
/// Appending one to another of the same type: [`Data::append`].
#[derive(Clone, Debug, PartialEq)]
pub enum Data {
    F32(Vec<f32>),
    F64(Vec<f64>),
    I64(Vec<i64>),
    U64(Vec<u64>),
    Bool(Vec<bool>),
    Str(Vec<String>),
    OptStr(Vec<Option<String>>),
    OptF64(Vec<Option<f64>>),
    OptU64(Vec<Option<u64>>),
    OptBool(Vec<Option<bool>>),
    ListStr(Vec<Vec<String>>),
    ListF32(Vec<f32>),
    ListF64(Vec<f64>),
    ListF16(Vec<u16>),
}

pub(crate) fn perr(path: &Path) -> impl Fn(ParquetError) -> DatasetError + '_ {
    move |e| DatasetError::parquet(path, e)
}

fn leaf(
    name: &str,
    physical: Physical,
    rep: Repetition,
    logical: Option<LogicalType>,
) -> Result<Type, ParquetError> {
    let mut b = Type::primitive_type_builder(name, physical)
        .with_repetition(rep)
        .with_logical_type(logical);
    if physical == Physical::FIXED_LEN_BYTE_ARRAY {
        b = b.with_length(2);
    }
    b.build()
}

/// `required group name (LIST) { repeated group list { <element, renamed `element`> } }`.
fn list(name: &str, element: Type) -> Result<Type, ParquetError> {
    let repeated = Type::group_type_builder("list")
        .with_repetition(Repetition::REPEATED)
        .with_fields(vec![Arc::new(element)])
        .build()?;
    Type::group_type_builder(name)
        .with_repetition(Repetition::REQUIRED)
        .with_logical_type(Some(LogicalType::List))
        .with_fields(vec![Arc::new(repeated)])
        .build()
}

fn nested(
    name: &str,
    shape: &[usize],
    physical: Physical,
    logical: Option<LogicalType>,
) -> Result<Type, ParquetError> {
    match shape {
        [] => leaf(name, physical, Repetition::REQUIRED, logical),
        [_, rest @ ..] => list(name, nested("element", rest, physical, logical)?),
    }
}

/// The schema of one column.
pub fn column_type(name: &str, kind: &Kind) -> Result<Type, ParquetError> {
    #[allow(non_snake_case)]
    let (O, R) = (Repetition::OPTIONAL, Repetition::REQUIRED);
    let u64t = Some(LogicalType::Integer {
        bit_width: 64,
        is_signed: false,
    });
    match kind {
        Kind::F32 => leaf(name, Physical::FLOAT, R, None),
        Kind::F64 => leaf(name, Physical::DOUBLE, R, None),
        Kind::I64 => leaf(name, Physical::INT64, R, None),
        Kind::U64 => leaf(name, Physical::INT64, R, u64t),
        Kind::Bool => leaf(name, Physical::BOOLEAN, R, None),
        Kind::Str => leaf(name, Physical::BYTE_ARRAY, R, Some(LogicalType::String)),
        Kind::OptStr => leaf(name, Physical::BYTE_ARRAY, O, Some(LogicalType::String)),
        Kind::OptF64 => leaf(name, Physical::DOUBLE, O, None),
        Kind::OptU64 => leaf(name, Physical::INT64, O, u64t),
        Kind::OptBool => leaf(name, Physical::BOOLEAN, O, None),
        Kind::ListStr => nested(name, &[0], Physical::BYTE_ARRAY, Some(LogicalType::String)),
        Kind::ListF32(shape) => nested(name, shape, Physical::FLOAT, None),
        Kind::ListF64(shape) => nested(name, shape, Physical::DOUBLE, None),
        Kind::ListF16(shape) => nested(
            name,
            shape,
            Physical::FIXED_LEN_BYTE_ARRAY,
            Some(LogicalType::Float16),
        ),
    }
}

fn schema(path: &Path, columns: &[(String, Kind)]) -> Result<Type, DatasetError> {
    let fields = columns
        .iter()
        .map(|(n, k)| column_type(n, k).map(Arc::new))
        .collect::<Result<Vec<_>, _>>()
        .map_err(perr(path))?;
    Type::group_type_builder("schema")
        .with_fields(fields)
        .build()
        .map_err(perr(path))
}

/// Repetition levels of one row of a fixed-shape feature: 0 at its start, then the depth of the outermost list
/// in which each further value starts a new element.
pub(crate) fn rep_pattern(shape: &[usize]) -> Vec<i16> {
    let n: usize = shape.iter().product();
    let mut out = Vec::with_capacity(n);
    for flat in 0..n {
        // Walk the dimensions innermost first: the first whose index is not 0 is where this value starts a new
        // element (its depth, 1 = outermost); a value with all indices 0 starts the row (0).
        let mut level = 0i16;
        let mut rest = flat;
        for (depth, &d) in shape.iter().enumerate().rev() {
            let d = d.max(1);
            if rest % d != 0 {
                level = depth as i16 + 1;
                break;
            }
            rest /= d;
        }
        out.push(level);
    }
    out
}

fn rows_of(data: &Data, kind: &Kind) -> usize {
    let per = |s: &Vec<usize>| s.iter().product::<usize>().max(1);
    match (data, kind) {
        (Data::F32(v), _) => v.len(),
        (Data::F64(v), _) => v.len(),
        (Data::I64(v), _) => v.len(),
        (Data::U64(v), _) => v.len(),
        (Data::Bool(v), _) => v.len(),
        (Data::Str(v), _) => v.len(),
        (Data::OptStr(v), _) => v.len(),
        (Data::OptF64(v), _) => v.len(),
        (Data::OptU64(v), _) => v.len(),
        (Data::OptBool(v), _) => v.len(),
        (Data::ListStr(v), _) => v.len(),
        (Data::ListF32(v), Kind::ListF32(s)) => v.len() / per(s),
        (Data::ListF64(v), Kind::ListF64(s)) => v.len() / per(s),
        (Data::ListF16(v), Kind::ListF16(s)) => v.len() / per(s),
        _ => usize::MAX,
    }
}

fn opt_levels<T: Clone>(v: &[Option<T>]) -> (Vec<T>, Vec<i16>) {
    let present = v.iter().flatten().cloned().collect();
    let def = v.iter().map(|x| i16::from(x.is_some())).collect();
    (present, def)
}

/// Values written (or read) per batch: bounds the level buffers and the converted values of wide features.
pub(crate) const BATCH_VALUES: usize = 1 << 16;

/// Rows per batch of a column with `per_row` values a row.
pub(crate) fn batch_rows(per_row: usize) -> usize {
    (BATCH_VALUES / per_row.max(1)).max(1)
}

/// Writes a fixed-shape column batch by batch, converting each batch's values with `convert`.
fn write_fixed<T: parquet::data_type::DataType, S>(
    w: &mut parquet::column::writer::ColumnWriterImpl<'_, T>,
    values: &[S],
    shape: &[usize],
    convert: impl Fn(&[S]) -> Vec<T::T>,
) -> Result<(), ParquetError> {
    let n: usize = shape.iter().product();
    let pattern = rep_pattern(shape);
    let depth = shape.len() as i16;
    for batch in values.chunks(n.max(1) * batch_rows(n)) {
        let def = vec![depth; batch.len()];
        let rep: Vec<i16> = pattern.iter().copied().cycle().take(batch.len()).collect();
        w.write_batch(&convert(batch), Some(&def), Some(&rep))?;
    }
    Ok(())
}

/// float16 bits as the parquet crate's fixed-length values (slices of one buffer, no allocation per value).
fn f16_values(bits: &[u16]) -> Vec<FixedLenByteArray> {
    let bytes = Bytes::from(
        bits.iter()
            .flat_map(|b| b.to_le_bytes())
            .collect::<Vec<u8>>(),
    );
    (0..bits.len())
        .map(|i| FixedLenByteArray::from(ByteArray::from(bytes.slice(2 * i..2 * i + 2))))
        .collect()
}

/// Serialises a table (one row group, snappy) into bytes, with `metadata` as the footer's key-value pairs.
pub fn write_table(
    path: &Path,
    columns: Vec<(String, Kind, Data)>,
    metadata: &[(String, String)],
) -> Result<Vec<u8>, DatasetError> {
    let err = perr(path);
    let kinds: Vec<(String, Kind)> = columns
        .iter()
        .map(|(n, k, _)| (n.clone(), k.clone()))
        .collect();
    let rows = columns.first().map_or(0, |(_, k, d)| rows_of(d, k));
    for (n, k, d) in &columns {
        if rows_of(d, k) != rows {
            return Err(DatasetError::parquet(
                path,
                format!("column `{n}` has a different number of rows"),
            ));
        }
    }
    let kv = (!metadata.is_empty()).then(|| {
        metadata
            .iter()
            .map(|(k, v)| KeyValue::new(k.clone(), v.clone()))
            .collect()
    });
    let props = WriterProperties::builder()
        .set_created_by(format!("vertibench datasets {}", env!("CARGO_PKG_VERSION")))
        .set_compression(Compression::SNAPPY)
        .set_key_value_metadata(kv)
        .build();
    let root = Arc::new(schema(path, &kinds)?);
    let mut writer = SerializedFileWriter::new(Vec::new(), root, Arc::new(props)).map_err(&err)?;
    let mut group = writer.next_row_group().map_err(&err)?;
    for (name, kind, data) in columns {
        let Some(mut col) = group.next_column().map_err(&err)? else {
            return Err(DatasetError::parquet(
                path,
                format!("schema has no column `{name}`"),
            ));
        };
        match write_column(&mut col, data, &kind) {
            Some(written) => written,
            None => {
                return Err(DatasetError::parquet(
                    path,
                    format!("column `{name}`: values do not fit its type"),
                ))
            }
        }
        .map_err(&err)?;
        col.close().map_err(&err)?;
    }
    group.close().map_err(&err)?;
    writer.into_inner().map_err(&err)
}

/// Writes one column's values; `None` when they do not fit its kind.
fn write_column(
    col: &mut SerializedColumnWriter<'_>,
    data: Data,
    kind: &Kind,
) -> Option<Result<(), ParquetError>> {
    Some(match (data, kind) {
        (Data::F32(v), _) => col
            .typed::<FloatType>()
            .write_batch(&v, None, None)
            .map(drop),
        (Data::F64(v), _) => col
            .typed::<DoubleType>()
            .write_batch(&v, None, None)
            .map(drop),
        (Data::I64(v), _) => col
            .typed::<Int64Type>()
            .write_batch(&v, None, None)
            .map(drop),
        (Data::U64(v), _) => {
            let v: Vec<i64> = v.iter().map(|&x| x as i64).collect();
            col.typed::<Int64Type>()
                .write_batch(&v, None, None)
                .map(drop)
        }
        (Data::Bool(v), _) => col
            .typed::<BoolType>()
            .write_batch(&v, None, None)
            .map(drop),
        (Data::Str(v), _) => {
            let v: Vec<ByteArray> = v.iter().map(|s| ByteArray::from(s.as_str())).collect();
            col.typed::<ByteArrayType>()
                .write_batch(&v, None, None)
                .map(drop)
        }
        (Data::OptStr(v), _) => {
            let (p, def) = opt_levels(&v);
            let p: Vec<ByteArray> = p.iter().map(|s| ByteArray::from(s.as_str())).collect();
            col.typed::<ByteArrayType>()
                .write_batch(&p, Some(&def), None)
                .map(drop)
        }
        (Data::OptF64(v), _) => {
            let (p, def) = opt_levels(&v);
            col.typed::<DoubleType>()
                .write_batch(&p, Some(&def), None)
                .map(drop)
        }
        (Data::OptU64(v), _) => {
            let (p, def) = opt_levels(&v);
            let p: Vec<i64> = p.iter().map(|&x| x as i64).collect();
            col.typed::<Int64Type>()
                .write_batch(&p, Some(&def), None)
                .map(drop)
        }
        (Data::OptBool(v), _) => {
            let (p, def) = opt_levels(&v);
            col.typed::<BoolType>()
                .write_batch(&p, Some(&def), None)
                .map(drop)
        }
        (Data::ListStr(v), _) => {
            let (vals, def, rep) = list_levels(&v);
            col.typed::<ByteArrayType>()
                .write_batch(&vals, Some(&def), Some(&rep))
                .map(drop)
        }
        (Data::ListF32(v), Kind::ListF32(shape)) => {
            write_fixed(col.typed::<FloatType>(), &v, shape, <[f32]>::to_vec)
        }
        (Data::ListF64(v), Kind::ListF64(shape)) => {
            write_fixed(col.typed::<DoubleType>(), &v, shape, <[f64]>::to_vec)
        }
        (Data::ListF16(v), Kind::ListF16(shape)) => {
            write_fixed(col.typed::<FixedLenByteArrayType>(), &v, shape, f16_values)
        }
        _ => return None,
    })
}

/// A list-of-strings column's values with their definition and repetition levels (an empty list: one undefined
/// value).
fn list_levels(rows: &[Vec<String>]) -> (Vec<ByteArray>, Vec<i16>, Vec<i16>) {
    let (mut vals, mut def, mut rep) = (Vec::new(), Vec::new(), Vec::new());
    for row in rows {
        if row.is_empty() {
            def.push(0);
            rep.push(0);
        }
        for (i, s) in row.iter().enumerate() {
            vals.push(ByteArray::from(s.as_str()));
            def.push(1);
            rep.push(i16::from(i > 0));
        }
    }
    (vals, def, rep)
}

impl Data {
    /// Appends `other`'s values (same type), as a table read batch by batch is assembled.
    pub fn append(&mut self, other: Data) -> Result<(), String> {
        match (self, other) {
            (Data::F32(a), Data::F32(b)) => a.extend(b),
            (Data::F64(a), Data::F64(b)) => a.extend(b),
            (Data::I64(a), Data::I64(b)) => a.extend(b),
            (Data::U64(a), Data::U64(b)) => a.extend(b),
            (Data::Bool(a), Data::Bool(b)) => a.extend(b),
            (Data::Str(a), Data::Str(b)) => a.extend(b),
            (Data::OptStr(a), Data::OptStr(b)) => a.extend(b),
            (Data::OptF64(a), Data::OptF64(b)) => a.extend(b),
            (Data::OptU64(a), Data::OptU64(b)) => a.extend(b),
            (Data::OptBool(a), Data::OptBool(b)) => a.extend(b),
            (Data::ListStr(a), Data::ListStr(b)) => a.extend(b),
            (Data::ListF32(a), Data::ListF32(b)) => a.extend(b),
            (Data::ListF64(a), Data::ListF64(b)) => a.extend(b),
            (Data::ListF16(a), Data::ListF16(b)) => a.extend(b),
            _ => return Err("values of another type".into()),
        }
        Ok(())
    }
}
