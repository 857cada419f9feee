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

/// The gRPC status of a service's error: its [`contracts::ServiceErrorCode`] by the one map, its message as it
/// displays.
pub fn status(e: &dyn contracts::ServiceError) -> tonic::Status {
    use contracts::ServiceErrorCode as C;
    let code = match e.error_code() {
        C::BadRequest => tonic::Code::InvalidArgument,
        C::Unauthenticated => tonic::Code::Unauthenticated,
        C::PermissionDenied => tonic::Code::PermissionDenied,
        C::NotFound => tonic::Code::NotFound,
        C::FailedPrecondition => tonic::Code::FailedPrecondition,
        C::Unavailable => tonic::Code::Unavailable,
        C::Internal => tonic::Code::Internal,
    };
    tonic::Status::new(code, e.to_string())
}

#[cfg(test)]
mod tests {
    use contracts::{ServiceError, ServiceErrorCode as C};

    #[derive(Debug, thiserror::Error)]
    #[error("no submission `s1`")]
    struct E(C);

    impl ServiceError for E {
        fn error_code(&self) -> C {
            self.0
        }
    }

    /// One code, one gRPC code and one HTTP status: no two codes share either.
    #[test]
    fn every_code_maps_to_its_own_grpc_and_http_status() {
        let all = [
            C::BadRequest,
            C::Unauthenticated,
            C::PermissionDenied,
            C::NotFound,
            C::FailedPrecondition,
            C::Unavailable,
            C::Internal,
        ];
        let grpc: std::collections::BTreeSet<i32> = all
            .iter()
            .map(|&c| super::status(&E(c)).code() as i32)
            .collect();
        let http: std::collections::BTreeSet<u16> = all.iter().map(|c| c.http_status()).collect();
        assert_eq!((grpc.len(), http.len()), (all.len(), all.len()));
        let s = super::status(&E(C::NotFound));
        assert_eq!(
            (s.code(), s.message()),
            (tonic::Code::NotFound, "no submission `s1`")
        );
        assert_eq!(C::NotFound.http_status(), 404);
    }
}
