//! `episodes.parquet`: the columns of `episodes.csv` ([`crate::report::episode_columns`]) in one row group,
//! written with the parquet crate's low-level column writers (no Arrow: the table is a handful of flat columns,
//! and leaving Arrow out keeps the build small). Types: text as `BYTE_ARRAY (UTF8)`, integers as `INT64`, metrics
//! as `DOUBLE` at full precision; `traversal_time_s` is an `OPTIONAL DOUBLE`, null for episodes that did not
//! succeed, and `terrain` an `OPTIONAL INT64`, null for worlds without a terrain group. Uncompressed (the file is about 300 kB for 1000 episodes; no codec crates to build).

use crate::report::{episode_columns, ColumnValues};
use crate::{io_err, EpisodeRow, ResultsError};
use ::parquet::data_type::{ByteArray, ByteArrayType, DoubleType, Int64Type};
use ::parquet::file::properties::WriterProperties;
use ::parquet::file::writer::SerializedFileWriter;
use ::parquet::schema::parser::parse_message_type;
use std::path::Path;
use std::sync::Arc;

/// The Parquet schema of the episode table.
pub fn schema(rows: &[EpisodeRow]) -> String {
    let mut m = String::from("message episodes {\n");
    for c in episode_columns(rows) {
        let t = match c.values {
            ColumnValues::Text(_) => "REQUIRED BYTE_ARRAY",
            ColumnValues::Int(_) => "REQUIRED INT64",
            ColumnValues::Float(..) => "REQUIRED DOUBLE",
            ColumnValues::OptFloat(..) => "OPTIONAL DOUBLE",
            ColumnValues::OptInt(_) => "OPTIONAL INT64",
        };
        let ann = if matches!(c.values, ColumnValues::Text(_)) {
            " (UTF8)"
        } else {
            ""
        };
        m += &format!("  {t} {}{ann};\n", c.name);
    }
    m + "}\n"
}

/// Writes the episode table to `path` (replacing it).
pub fn write_episodes(path: &Path, rows: &[EpisodeRow]) -> Result<(), ResultsError> {
    let err = |e: parquet::errors::ParquetError| io_err(path, e);
    let schema = Arc::new(parse_message_type(&schema(rows)).map_err(err)?);
    let props = Arc::new(
        WriterProperties::builder()
            .set_created_by(format!("vertibench eval {}", env!("CARGO_PKG_VERSION")))
            .build(),
    );
    let tmp = path.with_extension("parquet.tmp");
    let file = std::fs::File::create(&tmp).map_err(|e| io_err(&tmp, e))?;
    let mut writer = SerializedFileWriter::new(file, schema, props).map_err(err)?;
    let mut group = writer.next_row_group().map_err(err)?;
    for c in episode_columns(rows) {
        let Some(mut col) = group.next_column().map_err(err)? else {
            return Err(io_err(path, format!("schema has no column {}", c.name)));
        };
        match &c.values {
            ColumnValues::Text(v) => {
                let v: Vec<ByteArray> = v.iter().map(|s| ByteArray::from(s.as_str())).collect();
                col.typed::<ByteArrayType>()
                    .write_batch(&v, None, None)
                    .map_err(err)?;
            }
            ColumnValues::Int(v) => {
                col.typed::<Int64Type>()
                    .write_batch(v, None, None)
                    .map_err(err)?;
            }
            ColumnValues::Float(v, _) => {
                col.typed::<DoubleType>()
                    .write_batch(v, None, None)
                    .map_err(err)?;
            }
            ColumnValues::OptFloat(v, _) => {
                let present: Vec<f64> = v.iter().flatten().copied().collect();
                let def: Vec<i16> = v.iter().map(|x| i16::from(x.is_some())).collect();
                col.typed::<DoubleType>()
                    .write_batch(&present, Some(&def), None)
                    .map_err(err)?;
            }
            ColumnValues::OptInt(v) => {
                let present: Vec<i64> = v.iter().flatten().copied().collect();
                let def: Vec<i16> = v.iter().map(|x| i16::from(x.is_some())).collect();
                col.typed::<Int64Type>()
                    .write_batch(&present, Some(&def), None)
                    .map_err(err)?;
            }
        }
        col.close().map_err(err)?;
    }
    group.close().map_err(err)?;
    writer.close().map_err(err)?;
    std::fs::rename(&tmp, path).map_err(|e| io_err(path, e))
}
