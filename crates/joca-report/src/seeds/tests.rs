//! The seeds and panel tables against hand computations.

use super::*;
use joca_record::Method;

#[test]
fn the_t_interval_matches_a_hand_computation() {
    // 0.1, 0.2, 0.3: mean 0.2, s = 0.1, half-width t(0.975, 2)·0.1/√3 = 4.303·0.057735.
    let (m, h) = mean_interval(&[0.1, 0.2, 0.3]);
    assert!((m - 0.2).abs() < 1e-12);
    assert!((h - 4.302_653 * 0.1 / 3f64.sqrt()).abs() < 1e-7, "{h}");
    assert!(mean_interval(&[0.5]).1.is_nan());
    // Published quantiles (e.g. NIST/SEMATECH e-Handbook, Table of t, 1 − α/2 = 0.975).
    for (df, t) in [(1, 12.706_2), (2, 4.302_7), (5, 2.570_6), (10, 2.228_1), (30, 2.042_3)] {
        assert!((t_975(df) - t).abs() < 1e-4, "df {df}: {}", t_975(df));
    }
    assert!((t_975(100) - 1.984).abs() < 1e-3);
    assert!(t_975(0).is_nan());
}

/// Two differences that both print as −0.001 ± 0.001: only the one whose interval excludes 0
/// at full precision is marked; an interval from the closed form above that straddles 0, one
/// without a half-width and a missing mean are not.
#[test]
fn a_difference_is_marked_resolved_exactly_where_its_interval_excludes_zero() {
    assert_eq!(difference_text((-0.0010, 0.0009), 3), "-0.001 ± 0.001 ✱");
    assert_eq!(difference_text((-0.0010, 0.0011), 3), "-0.001 ± 0.001");
    assert_eq!(difference_cell((0.0123, 0.0122)), "0.012 ± 0.012 ✱");
    // 0.1, 0.2, 0.3: mean 0.2 ± 0.248 (the hand computation above) straddles 0.
    assert_eq!(difference_cell(mean_interval(&[0.1, 0.2, 0.3])), "0.200 ± 0.248");
    // [-0.1, -0.2, -0.3] mirrors it; [0.2, 0.21, 0.22]: mean 0.21 ± 4.303 · 0.01/√3 = 0.025.
    assert_eq!(difference_cell(mean_interval(&[-0.1, -0.2, -0.3])), "-0.200 ± 0.248");
    assert_eq!(difference_cell(mean_interval(&[0.2, 0.21, 0.22])), "0.210 ± 0.025 ✱");
    assert_eq!(difference_cell(mean_interval(&[0.02])), "0.020");
    assert_eq!(difference_cell(mean_interval(&[])), "–");
}

#[test]
fn variants_are_summarised_over_seeds_and_ours_is_paired_by_seed() {
    let row = |label: &str, method: Method, seed: u64, map: f64| {
        let mut results = crate::table::tests::results(map, 0.3, true);
        results.method = method;
        results.seed = seed;
        Row {
            group: "Calibrated".into(),
            label: label.into(),
            cell: format!("{label}-s{seed}"),
            design: String::new(),
            results,
        }
    };
    // Seeds listed out of order for the baseline: pairs are made by seed, not by position.
    let rows = vec![
        row("Ours", Method::Joca, 0, 0.30),
        row("Ours", Method::Joca, 1, 0.34),
        row("Ours", Method::Joca, 2, 0.32),
        row("FLIR", Method::FixedNeural, 2, 0.31),
        row("FLIR", Method::FixedNeural, 0, 0.25),
        row("FLIR", Method::FixedNeural, 1, 0.33),
    ];
    let (summary, paired) = tables(&rows);
    assert_eq!(summary.len(), 3);
    let h = t_975(2) * 0.02 / 3f64.sqrt();
    assert_eq!(summary[1][..3], ["Calibrated", "Ours", "3"]);
    assert_eq!(summary[1][3], format!("0.320 ± {h:.3}"));
    // Differences 0.05, 0.01, 0.01: mean 0.0233, s = 0.02309.
    assert_eq!(paired.len(), 2);
    assert_eq!(paired[1][1], "Ours − FLIR");
    let (m, hw) = mean_interval(&[0.05, 0.01, 0.01]);
    assert!((m - 0.07 / 3.0).abs() < 1e-12);
    assert_eq!(paired[1][3], format!("{m:.3} ± {hw:.3}"));
    assert_eq!(paired[1][5], "3 of 3 seeds");
    assert_eq!(paired[1][2], "3 seeds");
    let (md, html) = seeds_sections(&rows);
    assert!(md.contains("## Over seeds") && md.contains("Student's t"));
    assert!(html.contains("<th>Δ mAP</th>"));
    // One seed per variant: no section.
    assert_eq!(seeds_sections(&rows[..1]).0, "");
    // A follow-up town's rows get the same tables under the town's title, its cells counted.
    let (md, html) = town_sections(2, &rows);
    assert!(md.starts_with("## Town 2: the same cells on another town"), "{md}");
    assert!(md.contains("6 cells there") && md.contains("### Town 2: ours paired with each"));
    assert!(md.contains(&format!("| Calibrated | Ours − FLIR | 3 seeds | {m:.3} ± {hw:.3} |")));
    assert!(html.contains("<h2>Town 2"));
    assert_eq!(town_sections(2, &rows[..1]).0, "");
}

#[test]
fn a_panel_pairs_on_design_and_seed_and_takes_the_interval_over_designs() {
    let row = |label: &str, method: Method, design: &str, seed: u64, map: f64, night: f64| {
        let mut results = crate::table::tests::results(map, 0.3, false);
        results.method = method;
        results.seed = seed;
        let mut n = results.test;
        n.map = night;
        results.by_illumination.entry(joca_record::Light::Night).or_default().scores = Some(n);
        Row {
            group: "Calibrated".into(),
            label: label.into(),
            cell: format!("{label}-{design}-s{seed}"),
            design: design.into(),
            results,
        }
    };
    let (o, a) = (Method::Joca, Method::TacosAverage);
    // Design "a": ours − AverageAE 0.02 and 0.04 (mean 0.03); "b": −0.01 (one seed); "c":
    // 0.05 and 0.03 (mean 0.04). A baseline cell on another design or seed has no pair.
    let rows = vec![
        row("Ours", o, "a", 0, 0.32, 0.10),
        row("Ours", o, "a", 1, 0.34, 0.12),
        row("Ours", o, "b", 0, 0.20, 0.05),
        row("Ours", o, "c", 0, 0.45, 0.20),
        row("Ours", o, "c", 1, 0.43, 0.20),
        row("AverageAE", a, "a", 1, 0.30, 0.10),
        row("AverageAE", a, "a", 0, 0.30, 0.09),
        row("AverageAE", a, "b", 0, 0.21, 0.06),
        row("AverageAE", a, "c", 0, 0.40, 0.15),
        row("AverageAE", a, "c", 1, 0.40, 0.14),
        row("AverageAE", a, "d", 0, 0.90, 0.90),
    ];
    let (_, paired) = tables(&rows);
    let (m, h) = mean_interval(&[0.03, -0.01, 0.04]);
    assert!((m - 0.02).abs() < 1e-12);
    assert_eq!(paired[1][2], "3 designs × ≤ 2 seeds");
    assert_eq!(paired[1][3], format!("{m:.3} ± {h:.3}"));
    assert_eq!(paired[1][5], "2 of 3 designs");
    // Night: a 0.015 (0.01, 0.02), b −0.01, c 0.055 (0.05, 0.06).
    let lights = light_table(&rows);
    let (m, h) = mean_interval(&[0.015, -0.01, 0.055]);
    assert_eq!(lights[1][3], format!("{m:.3} ± {h:.3}"));
    assert_eq!(lights[1][2], "–", "no day scores recorded: {:?}", lights[1]);
    let designs = design_table(&rows);
    assert_eq!(designs.len(), 1 + 7, "4 designs of AverageAE, 3 of ours");
    let (md, _) = seeds_sections(&rows);
    assert!(md.contains("## Over designs and seeds"), "{md}");
    assert!(md.contains("4 panel designs (a, b, c, d)"), "{md}");
    assert!(md.contains("Not resolved: Ours − AverageAE"), "{md}");
    // A second scenario with one pair (design b): its difference, no interval, counted in
    // the singular.
    let mut more = rows.clone();
    for i in [2, 7] {
        more.push(Row { group: "Blur".into(), ..rows[i].clone() });
    }
    let (_, paired) = tables(&more);
    assert_eq!(paired[2][2], "1 design × 1 seed");
    let (md, _) = seeds_sections(&more);
    assert!(md.contains("(Blur, -0.010, one pair: no interval)"), "{md}");
    assert!(!md.contains("NaN"), "{md}");
    assert!(
        md.contains("Every cell ran on one machine type (CPU not recorded, scoring in fp32)."),
        "{md}"
    );
    // Design c's baseline cells repeated on another CPU, scored in bf16: two machine types
    // named with their counts, and the pairs that cross them counted per comparison.
    let mut mixed = rows.clone();
    for r in &mut mixed[8..10] {
        r.results.cpu = "AMD EPYC (AVX-512, AVX-512 BF16)".into();
        r.results.scoring_precision = Some(joca_core::compute::Precision::Bf16);
    }
    let (md, _) = seeds_sections(&mixed);
    assert!(
        md.contains(
            "Cells ran on 2 machine types (CPU not recorded, scoring in fp32: 9 cells; AMD EPYC \
             (AVX-512, AVX-512 BF16), scoring in bf16: 2 cells)"
        ),
        "{md}"
    );
    assert!(md.contains("0.020 ± ") && md.contains("; 2 of 5 pairs across machine types)"), "{md}");
}

/// Pooled over scenarios: per seed the mean of its scenario differences, then t over the seeds
/// present in both scenarios (seed 2 ran only in one and is left out).
#[test]
fn ours_pooled_over_scenarios_counts_each_seed_once() {
    let row = |group: &str, label: &str, method: Method, seed: u64, map: f64| {
        let mut results = crate::table::tests::results(map, 0.3, true);
        results.method = method;
        results.seed = seed;
        Row {
            group: group.into(),
            label: label.into(),
            cell: format!("{label}-{group}-s{seed}"),
            design: String::new(),
            results,
        }
    };
    let rows = vec![
        row("Calibrated", "Ours", Method::Joca, 0, 0.30),
        row("Calibrated", "Ours", Method::Joca, 1, 0.34),
        row("Calibrated", "Ours", Method::Joca, 2, 0.40),
        row("Calibrated", "TaCOS", Method::TacosAverage, 0, 0.28),
        row("Calibrated", "TaCOS", Method::TacosAverage, 1, 0.30),
        row("Calibrated", "TaCOS", Method::TacosAverage, 2, 0.20),
        row("Blur", "Ours", Method::Joca, 0, 0.20),
        row("Blur", "Ours", Method::Joca, 1, 0.22),
        row("Blur", "TaCOS", Method::TacosAverage, 0, 0.24),
        row("Blur", "TaCOS", Method::TacosAverage, 1, 0.20),
    ];
    // Seed 0: (0.02 − 0.04) / 2 = −0.01; seed 1: (0.04 + 0.02) / 2 = 0.03.
    let table = pooled::pooled_table(&rows);
    assert_eq!(table.len(), 2);
    let (m, h) = mean_interval(&[-0.01, 0.03]);
    assert_eq!(table[1][..3], ["Ours − TaCOS", "2", "2 seeds"]);
    assert_eq!(table[1][3], format!("{m:.3} ± {h:.3}"));
    assert_eq!(table[1][5], "1 of 2 seeds");
    // One scenario: nothing to pool.
    assert!(pooled::pooled_table(&rows[..6]).is_empty());
}

#[test]
fn pairs_split_by_distance_band_and_by_machine_type_match_hand_computations() {
    use joca_record::BandScores;
    // Two bands; band maps chosen so the differences are easy: ours − FLIR per seed.
    let band = |from: f64, to: f64, map: Option<f64>| BandScores {
        from_m: from,
        to_m: to,
        class_objects: [u64::from(map.is_some()), 0, 0],
        map,
        ap50: map,
        recall50: map,
    };
    let row = |label: &str, method: Method, seed: u64, near: f64, far: Option<f64>, cpu: &str| {
        let mut row = crate::table::tests::row(label, method, "", seed, near);
        row.results.cpu = cpu.to_owned();
        row.results.test_bands = vec![band(0.0, 20.0, Some(near)), band(20.0, 50.0, far)];
        row
    };
    let (a, b) = ("EPYC (AVX-512)", "Xeon (AVX2)");
    let rows = vec![
        row("Ours", Method::Joca, 0, 0.30, Some(0.10), a),
        row("Ours", Method::Joca, 1, 0.34, Some(0.14), a),
        row("Ours", Method::Joca, 2, 0.32, None, b),
        row("FLIR", Method::FixedNeural, 0, 0.25, Some(0.08), a),
        row("FLIR", Method::FixedNeural, 1, 0.33, Some(0.10), a),
        row("FLIR", Method::FixedNeural, 2, 0.31, Some(0.12), a),
    ];
    let bands = strata::band_table(&rows);
    assert_eq!(bands[0][3..], ["Δ mAP 0–20 m", "Δ mAP 20–50 m"]);
    // Near: 0.05, 0.01, 0.01 over three seeds; far: 0.02, 0.04 (seed 2 had no far objects).
    let near = mean_interval(&[0.05, 0.01, 0.01]);
    let far = mean_interval(&[0.02, 0.04]);
    assert_eq!(bands[1][3], format!("{:.3} ± {:.3}", near.0, near.1));
    assert_eq!(bands[1][4], format!("{:.3} ± {:.3}", far.0, far.1));
    // Machines: five cells on a, one on b; seeds 0 and 1 paired on a, seed 2 across both.
    let (counts, split) = strata::machine_tables(&rows);
    // A machine type as the "what the answer rests on" line names it: the CPU, the kernels and
    // subnormal handling where not joca's defaults, and the scoring precision.
    let type_of = |cpu: &str| format!("{cpu}, scoring in fp32");
    assert_eq!(counts[1..], [vec![type_of(a), "5".into()], vec![type_of(b), "1".into()]]);
    let on_a = mean_interval(&[0.05, 0.01]);
    assert_eq!(split.len(), 3, "{split:?}");
    assert_eq!(
        split[1][2..5],
        [type_of(a), "2 seeds".into(), format!("{:.3} ± {:.3}", on_a.0, on_a.1)]
    );
    assert_eq!(split[2][2..5], ["two machine types", "1 seed", "0.010"]);
    let (md, _) = seeds_sections(&rows);
    assert!(
        md.contains("### Paired, by distance band") && md.contains("### Paired, by machine type")
    );
    // One machine type: no machine section.
    let one: Vec<Row> = rows.into_iter().filter(|r| r.results.cpu == a).collect();
    assert!(strata::machine_tables(&one).0.is_empty());
    assert!(!seeds_sections(&one).0.contains("Machine types"));
}

#[test]
fn pooled_over_towns_averages_each_design_over_the_towns_then_takes_the_interval() {
    let row = |label: &str, method: Method, design: &str, map: f64| {
        crate::table::tests::row(label, method, design, 0, map)
    };
    let town = |ours: [f64; 2], base: [f64; 2]| {
        vec![
            row("Ours", Method::Joca, "a", ours[0]),
            row("Ours", Method::Joca, "b", ours[1]),
            row("AverageAE", Method::TacosAverage, "a", base[0]),
            row("AverageAE", Method::TacosAverage, "b", base[1]),
        ]
    };
    // Test town: a +0.05, b −0.02; town 2: a +0.09, b 0.00. Per design over towns: a 0.07,
    // b −0.01; mean 0.03, s = 0.0566, half-width t(0.975, 1) · 0.04 = 0.508.
    let test = town([0.30, 0.20], [0.25, 0.22]);
    let towns = vec![(2, town([0.40, 0.30], [0.31, 0.30]))];
    let table = pooled_towns_table(&test, &towns);
    assert_eq!(table.len(), 2);
    assert_eq!(table[1][..4], ["Calibrated", "Ours − AverageAE", "2", "2 designs"]);
    assert_eq!(table[1][4], "0.030 ± 0.508");
    assert_eq!(table[1][6], "1 of 2 designs");
    assert_eq!(table[1][7], "–", "r needs three designs");
    assert!(pooled_towns_table(&test, &[]).is_empty());
    // A follow-up town's sections list each design's variants there, as the test town's do.
    let (md, _) = town_sections(2, &towns[0].1);
    assert!(md.contains("### Town 2: per design"), "{md}");
    assert!(md.contains("| Calibrated | a |") && md.contains("| Ours | 1 | 0.400 |"), "{md}");
    assert!(md.contains("| AverageAE | 1 | 0.310 |"), "{md}");
}
