//! Generated types of the vertibench gRPC protocol, package `vertibench.v1`.
//!
//! These types stay at the service edge: the service crates convert them to and from sim-core's and the store's
//! own types (`convert` modules there); nothing below the services sees a protobuf type. The benchmark's vocabulary
//! (crate `contracts`: outcomes, end reasons, a world's factors, states, rules, metrics) maps to and from its
//! protobuf enums and messages in one place, [`convert`].

//!
//! [`tls`]: how clients (workers, `vb-submit`) open a channel to the coordinator, with TLS for `https://` URLs.

pub mod convert;
pub mod tls;

pub use convert::{ConvertError, ProtoEnum};

#[allow(clippy::all, clippy::pedantic)]
pub mod v1 {
    tonic::include_proto!("vertibench.v1");
}
