//! The native core of the `vertibench` Python package (`vertibench._core`): vector environments stepped in Rust
//! threads ([`py_vec::VecCore`]), in-process evaluation ([`py_eval::evaluate`]) the facts Python needs about the simulator, and task sets (the benchmark's compiled in, training sets generated
//! from a seed; [`task_data`]).

mod bench;
mod convert;
mod crops;
mod obs;
mod py_eval;
mod py_kino;
mod py_policy;
mod py_tal;
mod py_tnt;
mod py_vec;
mod slot;
mod source;
mod task_data;
mod threads;

use pyo3::prelude::*;

/// Names of the vehicles in the catalogue.
#[pyfunction]
fn vehicles() -> Vec<String> {
    sim_core::vehicle::builtin_vehicles()
        .into_iter()
        .map(|v| v.name)
        .collect()
}

/// The protocol's `.proto` files compiled at build time: a serialized `google.protobuf.FileDescriptorSet`.
const PROTO_DESCRIPTOR_SET: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/vertibench.fds"));

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("SIM_VERSION", sim_core::SIM_VERSION)?;
    m.add(
        "PROTO_DESCRIPTOR_SET",
        pyo3::types::PyBytes::new(m.py(), PROTO_DESCRIPTOR_SET),
    )?;
    m.add("STATE_FIELDS", obs::STATE_FIELDS.to_vec())?;
    m.add("GOAL_FIELDS", obs::GOAL_FIELDS.to_vec())?;
    m.add("SPLITS", eval::run::SPLITS.to_vec())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("BENCHMARK_SEED", tasks::generate::DEFAULT_SEED)?;
    m.add_function(wrap_pyfunction!(task_data::py_benchmark_dir, m)?)?;
    m.add_function(wrap_pyfunction!(task_data::benchmark_task_version, m)?)?;
    m.add_function(wrap_pyfunction!(task_data::generate, m)?)?;
    m.add_function(wrap_pyfunction!(task_data::task_set_info, m)?)?;
    m.add_function(wrap_pyfunction!(vehicles, m)?)?;
    m.add_class::<py_vec::VecCore>()?;
    m.add_class::<crops::CropMaker>()?;
    m.add_class::<py_policy::PolicyNet>()?;
    m.add_class::<py_kino::KinoData>()?;
    m.add_class::<py_kino::KinoNet>()?;
    m.add_class::<py_tal::TalNet>()?;
    m.add_class::<py_tnt::TravNet>()?;
    m.add_function(wrap_pyfunction!(py_tnt::tnt_grid_index, m)?)?;
    m.add_function(wrap_pyfunction!(py_policy::policy_features, m)?)?;
    m.add("POLICY_LAYOUT", learned::features::LAYOUT)?;
    m.add("POLICY_FEATURES", learned::features::FEATURES.to_vec())?;
    m.add("POLICY_CROP_SIZE", learned::features::CROP_SIZE)?;
    {
        use learned::kino::{features as kf, net as kn};
        m.add("KINO_LAYOUT", kf::LAYOUT)?;
        m.add("KINO_FEATURES", kf::FEATURES.to_vec())?;
        m.add("KINO_TARGETS", kf::TARGETS.to_vec())?;
        m.add("KINO_CROP_SIZE", kf::CROP_SIZE)?;
        m.add("KINO_CROP_META", kn::CROP_META)?;
        m.add("KINO_CODE", kn::CODE)?;
        m.add("KINO_STEP_FRAMES", kf::STEP_FRAMES)?;
        use learned::kino::tal;
        m.add("TAL_LAYOUT", tal::TAL_LAYOUT)?;
        m.add("TAL_OFFSETS", tal::OFFSETS.to_vec())?;
        m.add("TAL_MAP_SIZE", tal::MAP_SIZE)?;
        m.add("TAL_MAP_META", tal::MAP_META)?;
        m.add("TAL_ANCHOR_STEPS", tal::ANCHOR_STEPS)?;
        m.add("TAL_EMBED", tal::EMBED)?;
        m.add("TAL_GATE_HIDDEN", tal::GATE_HIDDEN)?;
        use learned::kino::tnt;
        m.add("TNT_LAYOUT", tnt::TNT_LAYOUT)?;
        m.add("TNT_CHANNELS", tnt::CHANNELS.to_vec())?;
        m.add("TNT_HEADINGS", tnt::HEADINGS)?;
        m.add("TNT_GRID", tnt::GRID)?;
    }
    m.add_function(wrap_pyfunction!(py_eval::evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(bench::raw_throughput, m)?)?;
    Ok(())
}
