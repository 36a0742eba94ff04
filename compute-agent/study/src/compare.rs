//! Two configurations walked on the same seeds, compared walk by walk: does a switch
//! change the walks beyond the spread of the seeds? Each seed fixes the start, the sweep
//! phase, the reaction time and the sensor noise, so the difference of a column between
//! the two configurations is taken per seed (a paired comparison) and summarised by its
//! mean and a 95 % confidence interval (Student's t, `n - 1` degrees of freedom). An
//! interval that contains 0 says the 20 (or N) walks cannot tell the two apart.

use serde::Serialize;

use super::study::Row;

/// The mean of paired differences with its 95 % confidence interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Difference {
    /// Mean of `base`.
    pub base_mean: f64,
    /// Mean of `versus`.
    pub versus_mean: f64,
    /// Mean of `versus - base` over the pairs.
    pub mean: f64,
    /// Lower end of the 95 % confidence interval.
    pub low: f64,
    /// Upper end of the 95 % confidence interval.
    pub high: f64,
    /// Number of pairs.
    pub n: usize,
    /// Pairs where `versus` is below `base`.
    pub lower: usize,
    /// Pairs where `versus` is above `base`.
    pub higher: usize,
}

impl Difference {
    /// Paired difference of `versus[i] - base[i]`; `None` for fewer than two pairs or
    /// slices of different lengths.
    pub fn paired(base: &[f64], versus: &[f64]) -> Option<Difference> {
        let n = base.len();
        if n < 2 || versus.len() != n {
            return None;
        }
        let d: Vec<f64> = base.iter().zip(versus).map(|(a, b)| b - a).collect();
        let mean_of = |xs: &[f64]| xs.iter().sum::<f64>() / n as f64;
        let mean = mean_of(&d);
        let var = d.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1) as f64;
        let half = t_975(n - 1) * (var / n as f64).sqrt();
        let lower = d.iter().filter(|&&x| x < 0.0).count();
        let higher = d.iter().filter(|&&x| x > 0.0).count();
        Some(Difference {
            base_mean: mean_of(base),
            versus_mean: mean_of(versus),
            mean,
            low: mean - half,
            high: mean + half,
            n,
            lower,
            higher,
        })
    }

    /// The interval lies wholly above or below 0.
    pub fn is_clear(&self) -> bool {
        self.low > 0.0 || self.high < 0.0
    }
}

/// The 0.975 quantile of Student's t with `df` degrees of freedom (two-sided 95 %).
/// Tabulated to 30 degrees of freedom; beyond, the Cornish-Fisher expansion around the
/// normal quantile (within 0.001 of the exact value from 30 on).
pub fn t_975(df: usize) -> f64 {
    const TABLE: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160, 2.145, 2.131,
        2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042,
    ];
    match df {
        0 => f64::INFINITY,
        1..=30 => TABLE[df - 1],
        _ => {
            let z: f64 = 1.959_964;
            let v = df as f64;
            z + (z.powi(3) + z) / (4.0 * v) + (5.0 * z.powi(5) + 16.0 * z.powi(3) + 3.0 * z) / (96.0 * v * v)
        }
    }
}

/// A compared column: name, unit factor, and the getter of its value in a row.
pub type Column = (&'static str, f64, fn(&Row) -> f64);

/// The columns compared: completion in percentage points, the rest per walk.
pub const COLUMNS: [Column; 7] = [
    ("time_s", 1.0, |r| r.time_s),
    ("signals", 1.0, |r| r.signals),
    ("cane", 1.0, |r| r.cane),
    ("body_in_fov", 1.0, |r| r.body_in_fov),
    ("body_out_fov", 1.0, |r| r.body_out_fov),
    ("head_high", 1.0, |r| r.body_head_high),
    ("completed_pct", 100.0, |r| r.completed),
];

/// Every column's paired difference, `versus` rows against `base` rows (same seeds in
/// the same order); `None` where there are fewer than two walks or the seeds differ.
pub fn compare(base: &[Row], versus: &[Row]) -> Option<Vec<(&'static str, Difference)>> {
    if base.len() != versus.len() || base.iter().zip(versus).any(|(a, b)| a.seed != b.seed) {
        return None;
    }
    COLUMNS
        .iter()
        .map(|&(name, unit, get)| {
            let a: Vec<f64> = base.iter().map(|r| unit * get(r)).collect();
            let b: Vec<f64> = versus.iter().map(|r| unit * get(r)).collect();
            Difference::paired(&a, &b).map(|d| (name, d))
        })
        .collect()
}

/// The comparison as text, one line per column: the two means, the difference, its
/// interval, in how many walks `versus` came out lower and higher, and whether the walks
/// tell the two apart.
pub fn lines(diffs: &[(&'static str, Difference)]) -> String {
    let mut s = format!(
        "{:<14} {:>9} {:>9} {:>9}  {:<18} {:>5} {:>6}\n",
        "column", "this", "versus", "diff", "95 % interval", "lower", "higher"
    );
    for (name, d) in diffs {
        let (a, b) = (d.base_mean, d.versus_mean);
        let verdict = if d.is_clear() {
            "differs"
        } else if d.low == 0.0 && d.high == 0.0 {
            "the same"
        } else {
            "within the spread of the seeds"
        };
        s.push_str(&format!(
            "{name:<14} {a:>9.2} {b:>9.2} {:>+9.2}  {:<18} {:>5} {:>6}  {verdict}\n",
            d.mean,
            format!("[{:+.2}, {:+.2}]", d.low, d.high),
            d.lower,
            d.higher
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paired_difference_of_five_pairs_has_students_interval() {
        // differences 1..5: mean 3, sd 1.5811, se 0.7071, t(4) = 2.776
        let base = [10.0, 10.0, 10.0, 10.0, 10.0];
        let versus = [11.0, 12.0, 13.0, 14.0, 15.0];
        let d = Difference::paired(&base, &versus).unwrap();
        assert_eq!(d.n, 5);
        assert!((d.mean - 3.0).abs() < 1e-12);
        assert!((d.high - d.mean - 2.776 * std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-6, "{d:?}");
        assert!(d.is_clear());
        // the same differences around 0 are not told apart
        let d = Difference::paired(&[0.0; 5], &[-2.0, -1.0, 0.0, 1.0, 2.0]).unwrap();
        assert_eq!(d.mean, 0.0);
        assert!(!d.is_clear() && d.low < 0.0 && d.high > 0.0);
        assert!(Difference::paired(&[1.0], &[2.0]).is_none());
        assert!(Difference::paired(&[1.0, 2.0], &[2.0]).is_none());
    }

    #[test]
    fn identical_walks_differ_by_exactly_nothing() {
        let d = Difference::paired(&[1.0, 4.0, 2.0], &[1.0, 4.0, 2.0]).unwrap();
        assert_eq!((d.mean, d.low, d.high), (0.0, 0.0, 0.0));
        assert!(!d.is_clear());
    }

    #[test]
    fn t_quantile_meets_the_normal_from_the_table_on() {
        assert_eq!(t_975(19), 2.093);
        assert!((t_975(31) - 2.0395).abs() < 0.001, "{}", t_975(31));
        assert!((t_975(39) - 2.0227).abs() < 0.001, "{}", t_975(39));
        assert!((t_975(120) - 1.9799).abs() < 0.001, "{}", t_975(120));
        assert!(t_975(0).is_infinite());
        // never below the normal quantile, falling with the degrees of freedom
        let mut last = f64::INFINITY;
        for df in 1..200 {
            let t = t_975(df);
            assert!(t > 1.959_96 && t <= last, "df {df}: {t}");
            last = t;
        }
    }

    fn row(seed: u64, cane: f64, completed: f64) -> Row {
        Row {
            seed: Some(seed),
            time_s: 50.0,
            signals: 10.0,
            cane,
            body_in_fov: 0.0,
            body_out_fov: 0.0,
            body_head_high: 0.0,
            reorientations: 0.0,
            assists: 0.0,
            completed,
        }
    }

    #[test]
    fn comparison_pairs_walks_by_seed_and_says_which_columns_differ() {
        let base = [row(1, 1.0, 1.0), row(2, 2.0, 1.0), row(3, 0.0, 1.0), row(4, 1.0, 1.0)];
        let versus = [row(1, 3.0, 1.0), row(2, 4.0, 0.0), row(3, 3.0, 1.0), row(4, 3.0, 1.0)];
        let diffs = compare(&base, &versus).unwrap();
        let get = |name: &str| diffs.iter().find(|(n, _)| *n == name).unwrap().1;
        assert_eq!(get("cane").mean, 2.25);
        assert!(get("cane").is_clear());
        assert_eq!((get("cane").lower, get("cane").higher), (0, 4));
        assert_eq!(get("completed_pct").mean, -25.0);
        assert!(!get("completed_pct").is_clear());
        assert_eq!((get("signals").low, get("signals").high), (0.0, 0.0));
        let text = lines(&diffs);
        assert!(text.contains("cane                1.00      3.25     +2.25  [+1.45, +3.05]"), "{text}");
        assert!(text.lines().any(|l| l.starts_with("completed_pct") && l.contains("   1      0  within")), "{text}");
        assert!(text.lines().any(|l| l.starts_with("cane") && l.ends_with("differs")), "{text}");
        assert!(text.lines().any(|l| l.starts_with("signals") && l.ends_with("the same")), "{text}");
        // walks of other seeds are not paired
        let shifted = [row(2, 3.0, 1.0), row(3, 4.0, 1.0), row(4, 3.0, 1.0), row(5, 3.0, 1.0)];
        assert!(compare(&base, &shifted).is_none());
    }
}
