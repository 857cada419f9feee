//! The client-driven simulator API (`Sim` service).
