//! Tokens (hashed, with roles) and worker registration.

use crate::*;
use sqlx::Row;

impl Store {
    // ---- tokens ----

    /// Creates a token named `name` with `role`; returns the token, which is shown once and stored only as a hash.
    /// The name is shown as its submissions' owner: control, bidirectional and invisible characters are refused.
    pub async fn create_token(&self, name: &str, role: TokenRole, now: f64) -> Result<String> {
        contracts::input::check_display_text("token name", name)?;
        let _w = self.write.lock().await;
        let token = format!("vbt_{}", random_hex(24)?);
        sqlx::query(
            "INSERT INTO tokens (id, name, hash, created_at, revoked, role) VALUES ($1, $2, $3, $4, 0, $5)",
        )
        .bind(random_hex(8)?)
        .bind(name)
        .bind(hash_token(&token))
        .bind(now)
        .bind(role.as_str())
        .execute(&self.pool)
        .await?;
        Ok(token)
    }

    /// The (unrevoked) token `token` is, if any.
    pub async fn check_token(&self, token: &str) -> Result<Option<Token>> {
        let row = sqlx::query("SELECT id, name, role FROM tokens WHERE hash = $1 AND revoked = 0")
            .bind(hash_token(token))
            .fetch_optional(&self.pool)
            .await?;
        let Some(r) = row else { return Ok(None) };
        let role: String = r.try_get("role")?;
        Ok(Some(Token {
            id: r.try_get("id")?,
            name: r.try_get("name")?,
            role: TokenRole::parse(&role)
                .ok_or_else(|| StoreError::Corrupt(format!("token role `{role}`")))?,
        }))
    }

    /// Revokes every token named `name`; returns how many.
    pub async fn revoke_tokens(&self, name: &str) -> Result<u64> {
        let _w = self.write.lock().await;
        let r = sqlx::query("UPDATE tokens SET revoked = 1 WHERE name = $1")
            .bind(name)
            .execute(&self.pool)
            .await?;
        Ok(r.rows_affected())
    }

    // ---- workers ----

    /// Registers a worker under the token `token_id`; returns its id.
    pub async fn register_worker(
        &self,
        name: &str,
        slots: u32,
        sim_version: &str,
        token_id: &str,
        now: f64,
    ) -> Result<String> {
        let _w = self.write.lock().await;
        let id = format!("wk-{}", random_hex(6)?);
        sqlx::query(
            "INSERT INTO workers (id, name, slots, sim_version, registered_at, last_seen, token_id)              VALUES ($1, $2, $3, $4, $5, $5, $6)",
        )
        .bind(&id)
        .bind(name)
        .bind(slots as i64)
        .bind(sim_version)
        .bind(now)
        .bind(token_id)
        .execute(&self.pool)
        .await?;
        Ok(id)
    }

    /// Whether `id` is a worker registered under the token `token_id` (and marks it seen).
    pub async fn touch_worker(&self, id: &str, token_id: &str, now: f64) -> Result<bool> {
        let _w = self.write.lock().await;
        let r = sqlx::query("UPDATE workers SET last_seen = $1 WHERE id = $2 AND token_id = $3")
            .bind(now)
            .bind(id)
            .bind(token_id)
            .execute(&self.pool)
            .await?;
        Ok(r.rows_affected() == 1)
    }
}
