//! `vb terrain ...`

use clap::Subcommand;

#[derive(Subcommand)]
pub enum TerrainCmd {
    /// Not implemented yet.
    Placeholder,
}

pub fn run(cmd: TerrainCmd) -> anyhow::Result<()> {
    match cmd {
        TerrainCmd::Placeholder => anyhow::bail!("vb terrain is not implemented yet"),
    }
}
