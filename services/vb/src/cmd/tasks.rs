//! `vb tasks ...`

use clap::Subcommand;

#[derive(Subcommand)]
pub enum TasksCmd {
    /// Not implemented yet.
    Placeholder,
}

pub fn run(cmd: TasksCmd) -> anyhow::Result<()> {
    match cmd {
        TasksCmd::Placeholder => anyhow::bail!("vb tasks is not implemented yet"),
    }
}
