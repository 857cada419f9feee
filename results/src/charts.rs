//! `charts.svg`: bar charts of the success rate (with its 95% interval) by elevation level, terrain semantics and
//! obstacle density. Rendered by the template `web/templates/charts.svg`, which escapes every value (the planner's
//! name is user-controlled on the service).

use crate::summary::named;
use crate::summary::{Aggregate, Summary};
use askama::Template;

/// Output of one of our templates: markup already escaped where it had to be, which a page embeds as it is.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Markup(String);

impl Markup {
    /// Renders a template. Rendering only fails when a value's `Display` fails, which none of ours does; the
    /// error text stands in for the markup then, so a page still renders.
    pub fn render(t: &impl Template) -> Markup {
        Markup(
            t.render()
                .unwrap_or_else(|e| format!("<!-- rendering failed: {e} -->")),
        )
    }

    pub fn into_string(self) -> String {
        self.0
    }
}

impl std::fmt::Display for Markup {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// One bar: its rectangle, interval whisker and labels, in pixels (formatted).
struct Bar {
    x: String,
    y: String,
    w: String,
    h: String,
    cx: String,
    ci_lo: String,
    ci_hi: String,
    name_y: String,
    name: String,
    pct_y: String,
    pct: String,
}

struct Panel {
    title: &'static str,
    x: String,
    y: String,
    bars: Vec<Bar>,
}

#[derive(Template)]
#[template(path = "charts.svg")]
struct Charts<'a> {
    width: f64,
    height: f64,
    planner: &'a str,
    panels: Vec<Panel>,
}

/// SVG bar charts of the success rate (with its interval) by elevation, semantics and obstacle density.
pub fn charts_svg(s: &Summary) -> Markup {
    let groups: [(&str, Vec<(&str, &Aggregate)>); 3] = [
        ("elevation level", named(&s.by_level)),
        ("terrain semantics", named(&s.by_semantics)),
        ("obstacle density", named(&s.by_density)),
    ];
    let (w, h, pad) = (900.0, 320.0, 40.0);
    let panel_w = (w - pad) / 3.0;
    let plot_h = h - 90.0;
    let y = |v: f64| 40.0 + plot_h * (1.0 - v);
    let f1 = |v: f64| format!("{v:.1}");
    let panels = groups
        .iter()
        .enumerate()
        .map(|(gi, (title, map))| {
            let x0 = pad / 2.0 + gi as f64 * panel_w;
            let bw = (panel_w - 40.0) / map.len().max(1) as f64;
            let bars = map
                .iter()
                .enumerate()
                .map(|(k, (name, a))| {
                    let bx = x0 + 20.0 + k as f64 * bw;
                    let cx = bx + bw / 2.0;
                    Bar {
                        x: f1(bx + 4.0),
                        y: f1(y(a.success_rate)),
                        w: f1(bw - 8.0),
                        h: f1(plot_h * a.success_rate),
                        cx: f1(cx),
                        ci_lo: f1(y(a.success_ci95.0)),
                        ci_hi: f1(y(a.success_ci95.1)),
                        name_y: f1(h - 30.0),
                        name: name.to_string(),
                        pct_y: f1(y(a.success_rate) - 4.0),
                        pct: format!("{:.0}%", 100.0 * a.success_rate),
                    }
                })
                .collect();
            Panel {
                title,
                x: format!("{:.0}", x0 + 10.0),
                y: format!("{:.0}", h - 8.0),
                bars,
            }
        })
        .collect();
    Markup::render(&Charts {
        width: w,
        height: h,
        planner: &s.planner,
        panels,
    })
}
