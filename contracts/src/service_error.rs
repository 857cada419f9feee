//! What kind of failure a service's error is, whatever carries it: each error type of the services says its
//! [`ServiceErrorCode`] once, and one map turns a code into a gRPC status (`vb_proto::status`) or an HTTP status
//! ([`ServiceErrorCode::http_status`]). Quickwit's `ServiceErrorCode` is the model.

/// See the module documentation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ServiceErrorCode {
    /// The request is malformed or names something invalid.
    BadRequest,
    /// No or an unknown credential.
    Unauthenticated,
    /// A valid credential that may not do this.
    PermissionDenied,
    /// What the request names does not exist.
    NotFound,
    /// The request is valid but the system is not in a state to serve it (another simulator version, ...).
    FailedPrecondition,
    /// The service cannot serve it now; retrying later may succeed.
    Unavailable,
    /// A failure of the service itself (a database error, a corrupt row).
    Internal,
}

impl ServiceErrorCode {
    /// The HTTP status of this code.
    pub fn http_status(self) -> u16 {
        match self {
            Self::BadRequest => 400,
            Self::Unauthenticated => 401,
            Self::PermissionDenied => 403,
            Self::NotFound => 404,
            Self::FailedPrecondition => 412,
            Self::Unavailable => 503,
            Self::Internal => 500,
        }
    }
}

/// An error a service returns to its client.
pub trait ServiceError: std::error::Error {
    fn error_code(&self) -> ServiceErrorCode;
}
