//! `episodes.parquet` holds the same columns and values as `episodes.csv`, read back with the parquet reader;
//! the traversal time of a failed episode and the terrain group of an ungrouped world are null (an empty CSV field).

use eval::summary::summarise;
use eval::EpisodeRow;
use parquet::file::reader::{FileReader, SerializedFileReader};
use parquet::record::Field;
use sim_core::episode::EpisodeMetrics;

fn row(task: u32, outcome: &str, time: f64) -> EpisodeRow {
    let mut metrics = EpisodeMetrics {
        time,
        path_length: 12.345678 * time,
        energy: 1234.56789 * time,
        obstacle_contacts: task,
        final_goal_distance: 3.0 / (1.0 + time),
        steps: (time / 0.004) as u64,
        ..Default::default()
    };
    metrics.roll.mean = -1.5 + 0.01 * time;
    metrics.pitch_abs.max = 29.87654321;
    metrics.steering_tv = 0.123456;
    EpisodeRow {
        task_id: contracts::TaskId::new(17, task),
        world_id: 17,
        task_index: task,
        level: "high".parse().unwrap(),
        semantics: "mixed".parse().unwrap(),
        density: "dense".parse().unwrap(),
        // Odd tasks come from a set without terrain groups: a null terrain.
        terrain: task.is_multiple_of(2).then_some(6),
        planner: "mppi6".into(),
        vehicle: "hmmwv".into(),
        scale: 1.0 / 6.0,
        seed: 7,
        task_set_version: "v1-abc".into(),
        sim_version: "sim-core 0.1.0".into(),
        rules: Default::default(),
        perception: Default::default(),
        outcome: outcome.parse().unwrap(),
        reason: outcome.parse().unwrap(),
        detail: String::new(),
        metrics,
        wall_time_s: 0.25 * time,
    }
}

#[test]
fn parquet_rows_equal_the_csv_rows_with_null_traversal_times_for_failures() {
    let rows = vec![
        row(0, "success", 31.25),
        row(1, "rollover", 12.5),
        row(2, "stuck", 17.0),
        row(3, "success", 44.004),
    ];
    let dir = std::env::temp_dir().join(format!("vb-parquet-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    eval::report::write(&dir, &rows, &summarise(&rows)).unwrap();
    let csv = std::fs::read_to_string(dir.join("episodes.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let csv_rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(csv_rows.len(), rows.len());

    let reader =
        SerializedFileReader::new(std::fs::File::open(dir.join("episodes.parquet")).unwrap())
            .unwrap();
    assert_eq!(
        reader.metadata().file_metadata().num_rows(),
        rows.len() as i64
    );
    let names: Vec<String> = reader
        .metadata()
        .file_metadata()
        .schema_descr()
        .columns()
        .iter()
        .map(|c| c.name().to_string())
        .collect();
    assert_eq!(names, header, "same columns in the same order");
    let mut n = 0;
    for (i, r) in reader.get_row_iter(None).unwrap().enumerate() {
        let r = r.unwrap();
        n += 1;
        for (j, (name, field)) in r.get_column_iter().enumerate() {
            let cell = csv_rows[i][j];
            assert_eq!(name, header[j]);
            match field {
                Field::Str(s) => assert_eq!(s, cell, "{name}"),
                Field::Long(v) => assert_eq!(v.to_string(), cell, "{name}"),
                Field::Double(v) => {
                    let decimals = cell.split_once('.').map_or(0, |(_, d)| d.len());
                    assert_eq!(format!("{v:.decimals$}"), cell, "{name} row {i}");
                }
                Field::Null => {
                    assert_eq!(cell, "", "empty CSV field for a null");
                    match name.as_str() {
                        "traversal_time_s" => assert!(!rows[i].is_success()),
                        "terrain" => assert_eq!(rows[i].terrain, None),
                        other => panic!("unexpected null in {other}"),
                    }
                }
                other => panic!("unexpected field {name}: {other:?}"),
            }
        }
        let tt = r
            .get_column_iter()
            .find(|(n, _)| n.as_str() == "traversal_time_s")
            .map(|(_, f)| f.clone())
            .unwrap();
        if rows[i].is_success() {
            assert_eq!(tt, Field::Double(rows[i].metrics.time), "full precision");
        } else {
            assert_eq!(tt, Field::Null);
        }
        let terrain = r
            .get_column_iter()
            .find(|(n, _)| n.as_str() == "terrain")
            .map(|(_, f)| f.clone())
            .unwrap();
        let want = rows[i]
            .terrain
            .map_or(Field::Null, |t| Field::Long(t.into()));
        assert_eq!(terrain, want);
    }
    assert_eq!(n, rows.len());
    std::fs::remove_dir_all(&dir).unwrap();
}
