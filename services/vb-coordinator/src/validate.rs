//! Validation of a submission before anything is stored: its name (no control, bidirectional or invisible
//! characters), planner (a builtin's name, an endpoint URL parsed as the worker will connect to it, an exec argv,
//! an image reference by Docker's grammar), vehicle, scale, deadline and task selection.

use crate::*;
use contracts::{input, Catalog, CatalogProfile, VehicleId};
use vb_store::PlannerSpec;

pub(crate) struct ValidSubmit {
    /// The request's submissions, one per perception profile (at least one), in its order.
    pub(crate) subs: Vec<NewSubmission>,
    pub(crate) episodes: Vec<NewEpisode>,
}

/// Most perception profiles one request may name.
const MAX_PROFILES: usize = 8;

impl Coordinator {
    pub(crate) fn validate_submit(&self, r: &pb::SubmitRequest) -> Result<ValidSubmit, Status> {
        let catalog = &self.cfg.catalog;
        let name = check_name(&r.name)?;
        let planner = self.planner(r.planner.as_ref())?;
        let (vehicle, scale) = vehicle_and_scale(catalog, &r.vehicle, r.scale)?;
        let deadline = step_deadline(r.step_deadline_s)?;
        let episodes = episodes(catalog, &r.task_ids)?;
        let profiles = perception(catalog, &r.perception)?;
        if let (PlannerSpec::Builtin(b), Some(p)) =
            (&planner, profiles.iter().find(|p| p.degrades_maps))
        {
            if !catalog.belief_planners.iter().any(|n| n == b) {
                return Err(bad(format!(
                    "builtin planner `{b}` reads the world's ground-truth maps, and perception profile {} degrades \
                     them: submit it under ideal",
                    p.entry.id
                )));
            }
        }
        let sub = NewSubmission {
            name: name.to_string(),
            owner: String::new(),
            owner_token: String::new(),
            planner_identity: match &planner {
                PlannerSpec::Builtin(_) => format!("{planner} ({})", catalog.sim_version),
                _ => planner.to_string(),
            },
            planner,
            vehicle,
            scale,
            seed: r.seed,
            step_deadline_s: deadline,
            task_set_version: catalog.task_set_version.clone(),
            sim_version: catalog.sim_version.clone(),
            perception: Default::default(),
        };
        let subs = profiles
            .into_iter()
            .map(|p| NewSubmission {
                perception: p.entry,
                ..sub.clone()
            })
            .collect();
        Ok(ValidSubmit { subs, episodes })
    }

    /// The planner as the store keeps it; exec and image planners only where this coordinator runs them.
    fn planner(&self, planner: Option<&pb::PlannerRef>) -> Result<PlannerSpec, Status> {
        let catalog = &self.cfg.catalog;
        let refuse = |what: &str| {
            Status::permission_denied(format!("this coordinator does not run {what} planners"))
        };
        Ok(match planner.and_then(|p| p.kind.as_ref()) {
            None => {
                return Err(bad(
                    "planner is missing: give an endpoint, exec argv, image or builtin".into(),
                ))
            }
            Some(pb::planner_ref::Kind::Builtin(b)) => {
                let names = &catalog.builtin_planners;
                if !names.iter().any(|n| n == b) {
                    let names: Vec<&str> = names.iter().map(|n| n.as_str()).collect();
                    return Err(bad(format!(
                        "unknown builtin planner `{b}` (available: {})",
                        names.join(", ")
                    )));
                }
                PlannerSpec::Builtin(b.into())
            }
            Some(pb::planner_ref::Kind::Endpoint(u)) => {
                check_endpoint(u).map_err(bad)?;
                PlannerSpec::Endpoint(u.clone())
            }
            Some(pb::planner_ref::Kind::Exec(e)) => {
                if !self.cfg.allow_exec {
                    return Err(refuse("exec"));
                }
                check_argv(&e.argv)?;
                PlannerSpec::Exec(e.argv.clone())
            }
            Some(pb::planner_ref::Kind::Image(i)) => {
                if !self.cfg.allow_exec {
                    return Err(refuse("container"));
                }
                input::check_image_ref(i).map_err(|e| bad(e.to_string()))?;
                PlannerSpec::Image(i.clone())
            }
        })
    }
}

fn bad(m: String) -> Status {
    Status::invalid_argument(m)
}

/// The catalogue's profiles a request names (none: `ideal`), each at most once.
fn perception(catalog: &Catalog, names: &[String]) -> Result<Vec<CatalogProfile>, Status> {
    if names.len() > MAX_PROFILES {
        return Err(bad(format!(
            "at most {MAX_PROFILES} perception profiles per submission (got {})",
            names.len()
        )));
    }
    if names.is_empty() {
        return Ok(vec![CatalogProfile::default()]);
    }
    let mut out: Vec<CatalogProfile> = Vec::with_capacity(names.len());
    for n in names {
        let entry = catalog.perception_profile(n.trim()).map_err(bad)?;
        if out.iter().any(|e| e.entry.id == entry.entry.id) {
            return Err(bad(format!("perception profile `{n}` is named twice")));
        }
        out.push(entry);
    }
    Ok(out)
}

/// The submission's name, trimmed: 1 to `MAX_NAME` characters of displayable text.
fn check_name(raw: &str) -> Result<&str, Status> {
    let name = raw.trim();
    if name.is_empty() || name.chars().count() > MAX_NAME {
        return Err(bad(format!(
            "name must be 1 to {MAX_NAME} printable characters (got {} characters)",
            raw.chars().count()
        )));
    }
    input::check_display_text("name", raw).map_err(|e| bad(e.to_string()))?;
    Ok(name)
}

/// An exec planner's argv: 1 to `MAX_ARGV` arguments of at most `MAX_ARG_LEN` bytes, the program named.
fn check_argv(argv: &[String]) -> Result<(), Status> {
    if argv.is_empty() || argv.len() > MAX_ARGV || argv.iter().any(|a| a.len() > MAX_ARG_LEN) {
        return Err(bad(format!(
            "exec argv must have 1 to {MAX_ARGV} arguments of at most {MAX_ARG_LEN} bytes"
        )));
    }
    if argv[0].trim().is_empty() {
        return Err(bad("exec argv[0] (the program) is empty".into()));
    }
    Ok(())
}

/// The catalogue's vehicle (default `hmmwv`) and the scale (0: the vehicle's own), in (0, 1].
fn vehicle_and_scale(
    catalog: &Catalog,
    vehicle: &str,
    scale: f64,
) -> Result<(VehicleId, f64), Status> {
    let name = if vehicle.is_empty() { "hmmwv" } else { vehicle };
    let Some(&own) = catalog.vehicles.get(name) else {
        let names: Vec<&str> = catalog.vehicles.keys().map(|v| v.as_str()).collect();
        return Err(bad(format!(
            "vehicle: unknown vehicle `{name}` (available: {})",
            names.join(", ")
        )));
    };
    let s = if scale == 0.0 { own } else { scale };
    if !(s.is_finite() && s > 0.0 && s <= 1.0) {
        return Err(bad(format!(
            "scale {scale} must be in (0, 1] (0 = the vehicle's own)"
        )));
    }
    Ok((name.into(), s))
}

/// The per-step deadline (0: the default, 1 s), in (0, 60] s.
fn step_deadline(given: f64) -> Result<f64, Status> {
    let deadline = if given == 0.0 { 1.0 } else { given };
    if !(deadline.is_finite() && deadline > 0.0 && deadline <= 60.0) {
        return Err(bad(format!(
            "step_deadline_s {given} must be in (0, 60] (0 = the default, 1 s)"
        )));
    }
    Ok(deadline)
}

/// The selected tasks (none given: all), with the factors the board breaks results down by.
fn episodes(catalog: &Catalog, task_ids: &[String]) -> Result<Vec<NewEpisode>, Status> {
    if task_ids.len() > 10_000 || task_ids.iter().any(|t| t.len() > 64) {
        return Err(bad("too many or too long task ids".into()));
    }
    let spec = if task_ids.is_empty() {
        "all".to_string()
    } else {
        task_ids.join(",")
    };
    let selected = catalog.select(&spec).map_err(|e| bad(e.to_string()))?;
    // Selected from the catalog, so every task's world is in it.
    Ok(selected
        .into_iter()
        .filter_map(|id| NewEpisode::of(catalog, id))
        .collect())
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
