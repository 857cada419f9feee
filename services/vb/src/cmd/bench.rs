//! `vb bench ...`

use clap::Subcommand;

#[derive(Subcommand)]
pub enum BenchCmd {
    /// Not implemented yet.
    Placeholder,
}

pub fn run(cmd: BenchCmd) -> anyhow::Result<()> {
    match cmd {
        BenchCmd::Placeholder => anyhow::bail!("vb bench is not implemented yet"),
    }
}
