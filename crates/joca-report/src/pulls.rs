//! DF-Grad's two pulls on NeuralAE over a run (issue 71's question: can l_GA move the policy
//! where the task gradient cannot?). Every logged step records the task loss's pull on NeuralAE's
//! exposure and gain, `w_task · ∂l_task/∂u` with u each setting's unit position in its range;
//! l_GA, an L1 in the same units with weight 1, pulls each by 1/2 on the steps it applies. Per
//! light: the task pull's median (its sign: negative asks for more light), its median size and
//! the share of steps on which it asked for more exposure.

use crate::event_log::StepLog;
use joca_record::Light;
use std::fmt::Write as _;

/// l_GA's pull on each unit where it applies (weight 1, mean of two L1 terms).
const GA_PULL: f64 = 0.5;

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

/// The pulls section of a run report; empty where no step recorded the task's pull.
pub fn pulls_markdown(steps: &[StepLog]) -> String {
    let recorded: Vec<&StepLog> = steps.iter().filter(|s| s.task_gradient.is_some()).collect();
    if recorded.is_empty() {
        return String::new();
    }
    let ga = recorded.iter().filter(|s| s.ga).count();
    let mut md = format!(
        "## DF-Grad's pulls on NeuralAE\n\nThe task loss's pull on NeuralAE's exposure and gain \
            outputs (w_task · ∂l_task/∂u, u each setting's place in its range; negative: more \
            light lowers the loss) over the {} logged training steps NeuralAE set; l_GA pulls \
            each by {GA_PULL} on the steps it applies ({ga} of them here).\n\n| light | steps | \
            exposure: median pull | median size | asks for more exposure | gain: median pull | \
            median size |\n|---|---|---|---|---|---|---|\n",
        recorded.len()
    );
    let lights: Vec<Option<Light>> = [Light::Day, Light::Night, Light::Tunnel, Light::Cycle]
        .into_iter()
        .map(Some)
        .chain([None])
        .collect();
    for light in lights {
        let of: Vec<[f64; 2]> = recorded
            .iter()
            .filter(|s| light.is_none() || s.light == light)
            .filter_map(|s| s.task_gradient)
            .collect();
        if of.is_empty() {
            continue;
        }
        let e: Vec<f64> = of.iter().map(|g| g[0]).collect();
        let g: Vec<f64> = of.iter().map(|g| g[1]).collect();
        let more = e.iter().filter(|v| **v < 0.0).count() as f64 / e.len() as f64;
        let _ = writeln!(
            md,
            "| {} | {} | {:.3} | {:.3} | {:.0} % | {:.3} | {:.3} |",
            light.map_or("all", Light::name),
            of.len(),
            median(e.clone()),
            median(e.iter().map(|v| v.abs()).collect()),
            100.0 * more,
            median(g.clone()),
            median(g.iter().map(|v| v.abs()).collect()),
        );
    }
    md.push('\n');
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    fn step(e: f64, g: f64, ga: bool, light: Light) -> StepLog {
        StepLog {
            step: 0,
            loss: 1.0,
            exposure_ms: 5.0,
            gain_db: 10.0,
            task_gradient: Some([e, g]),
            ga,
            light: Some(light),
        }
    }

    #[test]
    fn the_pulls_table_gives_medians_signs_and_shares_per_light() {
        let steps = [
            step(-0.2, -0.1, true, Light::Night),
            step(-0.4, 0.3, false, Light::Night),
            step(0.1, 0.05, false, Light::Day),
            StepLog { task_gradient: None, ..step(0.0, 0.0, false, Light::Day) },
        ];
        let md = pulls_markdown(&steps);
        assert!(
            md.contains("over the 3 logged training steps") && md.contains("(1 of them"),
            "{md}"
        );
        assert!(md.contains("| night | 2 | -0.300 | 0.300 | 100 % | 0.100 | 0.200 |"), "{md}");
        assert!(md.contains("| day | 1 | 0.100 | 0.100 | 0 % | 0.050 | 0.050 |"), "{md}");
        assert!(md.contains("| all | 3 | -0.200 | 0.200 | 67 % | 0.050 | 0.100 |"), "{md}");
        assert!(pulls_markdown(&steps[3..]).is_empty());
    }
}
