//! `vb sim ...`

use clap::Subcommand;

#[derive(Subcommand)]
pub enum SimCmd {
    /// Not implemented yet.
    Placeholder,
}

pub fn run(cmd: SimCmd) -> anyhow::Result<()> {
    match cmd {
        SimCmd::Placeholder => anyhow::bail!("vb sim is not implemented yet"),
    }
}
