//! `vb admin`: tokens in the service's store.

use super::args::{AdminCmd, TokenCmd};
use super::common::{admin_store, runtime};
use anyhow::bail;

pub fn admin(c: AdminCmd) -> anyhow::Result<()> {
    runtime()?.block_on(async move {
        match c {
            AdminCmd::Token(TokenCmd::Create { name, role, db }) => {
                if name.trim().is_empty() {
                    bail!("--name must not be empty");
                }
                let store = admin_store(db.as_deref()).await?;
                let token = store
                    .create_token(&name, role, vb_coordinator::now())
                    .await?;
                eprintln!(
                    "{} token for `{name}` (shown once; the store keeps only its SHA-256):",
                    role.as_str()
                );
                println!("{token}");
            }
            AdminCmd::Token(TokenCmd::Revoke { name, db }) => {
                let store = admin_store(db.as_deref()).await?;
                let n = store.revoke_tokens(&name).await?;
                println!("revoked {n} token(s) named `{name}`");
            }
        }
        Ok(())
    })
}
