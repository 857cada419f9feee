//! Client side of TLS to the coordinator (workers and `vb-submit`): an `https://` URL is verified against the CA
//! certificate given (a cluster's own CA, or a self-signed server certificate), or against the public web PKI
//! roots when none is given. An `http://` URL is plaintext (a private network or loopback).

use std::path::Path;
use std::time::Duration;
use tonic::transport::{Certificate, ClientTlsConfig, Endpoint};

/// An endpoint for `url`, with TLS when it is `https://`.
pub fn endpoint(url: &str, ca: Option<&Path>) -> Result<Endpoint, String> {
    let ep = Endpoint::from_shared(url.to_string())
        .map_err(|e| format!("`{url}` is not a valid URL: {e}"))?
        .connect_timeout(Duration::from_secs(5));
    if !url.starts_with("https://") {
        if ca.is_some() {
            return Err(format!(
                "a CA certificate was given but `{url}` is not https://: use https:// to connect with TLS"
            ));
        }
        return Ok(ep);
    }
    let tls = match ca {
        Some(path) => {
            let pem = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
            ClientTlsConfig::new().ca_certificate(Certificate::from_pem(pem))
        }
        None => ClientTlsConfig::new().with_webpki_roots(),
    };
    ep.tls_config(tls)
        .map_err(|e| format!("TLS configuration for `{url}`: {e}"))
}
