//! A token's name is shown as its submissions' owner: names with control, bidirectional or invisible characters are
//! refused, naming the character.

use vb_store::*;

#[allow(dead_code)]
mod common;

use common::*;

#[tokio::test]
async fn token_names_with_hidden_characters_are_refused() -> anyhow::Result<()> {
    for url in backends("token-names").await? {
        let store = Store::open(&url).await?;
        let e = store
            .create_token("ali\u{202E}ce", TokenRole::User, 1.0)
            .await
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("token name") && e.contains("U+202E"),
            "{url}: {e}"
        );
        let e = store
            .create_token("bob\u{200B}", TokenRole::Worker, 1.0)
            .await
            .unwrap_err()
            .to_string();
        assert!(e.contains("U+200B"), "{url}: {e}");
        store
            .create_token("Zoë (lab 3)", TokenRole::User, 1.0)
            .await?;
    }
    Ok(())
}
