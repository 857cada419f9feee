//! Validation of a submission before anything is stored: its name (no control, bidirectional or invisible
//! characters), planner (a builtin's name, an endpoint URL parsed as the worker will connect to it, an exec argv,
//! an image reference by Docker's grammar), vehicle, scale, deadline and task selection.

use crate::*;
use contracts::{input, PlannerKind};

pub(crate) struct ValidSubmit {
    pub(crate) sub: NewSubmission,
    pub(crate) episodes: Vec<NewEpisode>,
}

impl Coordinator {
    pub(crate) fn validate_submit(&self, r: &pb::SubmitRequest) -> Result<ValidSubmit, Status> {
        let catalog = &self.cfg.catalog;
        let bad = |m: String| Status::invalid_argument(m);
        let name = r.name.trim();
        if name.is_empty() || name.chars().count() > MAX_NAME {
            return Err(bad(format!(
                "name must be 1 to {MAX_NAME} printable characters (got {} characters)",
                r.name.chars().count()
            )));
        }
        input::check_display_text("name", &r.name).map_err(|e| bad(e.to_string()))?;
        let (kind, spec) = match r.planner.as_ref().and_then(|p| p.kind.as_ref()) {
            None => {
                return Err(bad(
                    "planner is missing: give an endpoint, exec argv, image or builtin".into(),
                ))
            }
            Some(pb::planner_ref::Kind::Builtin(b)) => {
                let names = &catalog.builtin_planners;
                if !names.contains(b) {
                    return Err(bad(format!(
                        "unknown builtin planner `{b}` (available: {})",
                        names.join(", ")
                    )));
                }
                (PlannerKind::Builtin, b.clone())
            }
            Some(pb::planner_ref::Kind::Endpoint(u)) => {
                check_endpoint(u).map_err(bad)?;
                (PlannerKind::Endpoint, u.clone())
            }
            Some(pb::planner_ref::Kind::Exec(e)) => {
                if !self.cfg.allow_exec {
                    return Err(Status::permission_denied(
                        "this coordinator does not run exec planners",
                    ));
                }
                if e.argv.is_empty()
                    || e.argv.len() > MAX_ARGV
                    || e.argv.iter().any(|a| a.len() > MAX_ARG_LEN)
                {
                    return Err(bad(format!(
                        "exec argv must have 1 to {MAX_ARGV} arguments of at most {MAX_ARG_LEN} bytes"
                    )));
                }
                if e.argv[0].trim().is_empty() {
                    return Err(bad("exec argv[0] (the program) is empty".into()));
                }
                (
                    PlannerKind::Exec,
                    serde_json::to_string(&e.argv).map_err(|e| Status::internal(e.to_string()))?,
                )
            }
            Some(pb::planner_ref::Kind::Image(i)) => {
                if !self.cfg.allow_exec {
                    return Err(Status::permission_denied(
                        "this coordinator does not run container planners",
                    ));
                }
                input::check_image_ref(i).map_err(|e| bad(e.to_string()))?;
                (PlannerKind::Image, i.clone())
            }
        };
        let vehicle_name = if r.vehicle.is_empty() {
            "hmmwv"
        } else {
            r.vehicle.as_str()
        };
        let Some(&vehicle_scale) = catalog.vehicles.get(vehicle_name) else {
            let names: Vec<&str> = catalog.vehicles.keys().map(String::as_str).collect();
            return Err(bad(format!(
                "vehicle: unknown vehicle `{vehicle_name}` (available: {})",
                names.join(", ")
            )));
        };
        let scale = if r.scale == 0.0 {
            vehicle_scale
        } else {
            r.scale
        };
        if !(scale.is_finite() && scale > 0.0 && scale <= 1.0) {
            return Err(bad(format!(
                "scale {} must be in (0, 1] (0 = the vehicle's own)",
                r.scale
            )));
        }
        let deadline = if r.step_deadline_s == 0.0 {
            1.0
        } else {
            r.step_deadline_s
        };
        if !(deadline.is_finite() && deadline > 0.0 && deadline <= 60.0) {
            return Err(bad(format!(
                "step_deadline_s {} must be in (0, 60] (0 = the default, 1 s)",
                r.step_deadline_s
            )));
        }
        if r.task_ids.len() > 10_000 || r.task_ids.iter().any(|t| t.len() > 64) {
            return Err(bad("too many or too long task ids".into()));
        }
        let spec_str = if r.task_ids.is_empty() {
            "all".to_string()
        } else {
            r.task_ids.join(",")
        };
        let selected = catalog.select(&spec_str).map_err(|e| bad(e.to_string()))?;
        // Selected from the catalog, so every task's world is in it.
        let episodes = selected
            .into_iter()
            .filter_map(|id| NewEpisode::of(catalog, id))
            .collect();
        Ok(ValidSubmit {
            sub: NewSubmission {
                name: name.to_string(),
                owner: String::new(),
                owner_token: String::new(),
                planner_kind: kind,
                planner_identity: match kind {
                    PlannerKind::Builtin => format!("builtin:{spec} ({})", catalog.sim_version),
                    _ => format!("{kind}:{spec}"),
                },
                planner_spec: spec,
                vehicle: vehicle_name.to_string(),
                scale,
                seed: r.seed,
                step_deadline_s: deadline,
                task_set_version: catalog.task_set_version.clone(),
                sim_version: catalog.sim_version.clone(),
            },
            episodes,
        })
    }
}

/// Checks a planner endpoint URL: `http://` or `https://` with a host (and optionally a port), parsed as the worker's
/// gRPC client will parse it; no credentials, path, query or fragment (gRPC serves at the root), no whitespace or
/// control characters.
pub(crate) fn check_endpoint(u: &str) -> Result<(), String> {
    let bad = |why: &str| Err(format!("endpoint `{u}` is not a planner URL: {why}"));
    if u.len() > MAX_SPEC_LEN {
        return bad(&format!("longer than {MAX_SPEC_LEN} bytes"));
    }
    if let Some(c) = u.chars().find(|c| c.is_whitespace() || c.is_control()) {
        return bad(&format!("it contains U+{:04X}", c as u32));
    }
    let url = match url::Url::parse(u) {
        Ok(url) => url,
        Err(e) => {
            return bad(&format!(
                "{e} (expected http://HOST:PORT or https://HOST:PORT)"
            ))
        }
    };
    if !matches!(url.scheme(), "http" | "https") {
        return bad(&format!(
            "scheme `{}` is not http:// or https://",
            url.scheme()
        ));
    }
    if url.host_str().is_none_or(str::is_empty) {
        return bad("it has no host");
    }
    if !url.username().is_empty() || url.password().is_some() {
        return bad("credentials in the URL are not supported");
    }
    if url.path() != "/" || url.query().is_some() || url.fragment().is_some() {
        return bad("a gRPC planner serves at the root: give no path, query or fragment");
    }
    // The worker connects with tonic, which parses the text itself: it must agree.
    if let Err(e) = u.parse::<tonic::transport::Uri>() {
        return bad(&e.to_string());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::check_endpoint;

    #[test]
    fn endpoints_are_parsed_urls_with_a_host() {
        for ok in [
            "http://127.0.0.1:50052",
            "https://planner.example.com",
            "http://planner.example.com:8080/",
            "http://[::1]:9000",
            "HTTP://Host.Example:1",
        ] {
            assert_eq!(check_endpoint(ok), Ok(()), "{ok}");
        }
        for (bad, why) in [
            ("http://[bad", "invalid IPv6 address"),
            ("http://", "empty host"),
            ("http://:80", "empty host"),
            ("ftp://x", "scheme `ftp`"),
            ("unix:/tmp/s", "scheme `unix`"),
            ("http:/x", "not a planner URL"),
            ("x", "relative URL"),
            ("http://a b", "U+0020"),
            ("http://a\tb", "U+0009"),
            ("http://host:99999", "invalid port"),
            ("http://user:pw@host", "credentials"),
            ("http://host/path", "no path"),
            ("http://host?q=1", "no path"),
            ("http://host#f", "no path"),
        ] {
            let e = check_endpoint(bad).expect_err(bad);
            assert!(
                e.starts_with(&format!("endpoint `{bad}`")) && e.contains(why),
                "{bad}: {e}"
            );
        }
    }
}
