//! The search of a fit: Nelder-Mead in the unit cube of the parameters,
//! after a coarse scan (see the module doc of [`crate::fit`]).

use super::{Bound, FitError, FitResult, Observer, Problem, reason};

/// A simplex: `d + 1` points in unit coordinates with their penalised
/// misfits.
type Simplex = Vec<(Vec<f64>, f64)>;

/// Sort a simplex best first.
fn order(s: &mut Simplex) {
    s.sort_by(|a, b| a.1.total_cmp(&b.1));
}

/// A search under way: every model run so far.
struct Search<'p, 'o> {
    problem: &'p Problem,
    observe: &'p mut Observer<'o>,
    /// Every model run: parameter values and misfit.
    history: Vec<(Vec<f64>, f64)>,
    /// The runs the scene rejected: index in `history`, and why.
    rejected: Vec<(usize, String)>,
    /// Calls of [`Search::f`], repeated points included.
    calls: usize,
}

impl Search<'_, '_> {
    /// The parameter values at unit coordinates `x`.
    fn values(&self, x: &[f64]) -> Vec<f64> {
        self.problem
            .params
            .iter()
            .zip(x)
            .map(|(p, &u)| p.value_at(u))
            .collect()
    }

    /// The misfit recorded at `values`, if they were run.
    fn recorded(&self, values: &[f64]) -> Option<f64> {
        self.history.iter().find(|(v, _)| *v == values).map(|h| h.1)
    }

    /// The function minimised, on unconstrained unit coordinates: the
    /// misfit at the clamped point plus the squared distance outside the
    /// cube. A point already run is not run again.
    fn f(&mut self, x: &[f64]) -> f64 {
        self.calls += 1;
        let outside: f64 = x.iter().map(|&u| (u - u.clamp(0.0, 1.0)).powi(2)).sum();
        let values = self.values(x);
        let g = match self.recorded(&values) {
            Some(g) => g,
            None => {
                let (g, why) = match self.problem.model(&values) {
                    Ok(m) => (self.problem.misfit_of(&m), None),
                    Err(e) => (f64::INFINITY, Some(reason(&e.0))),
                };
                self.history.push((values.clone(), g));
                (self.observe)(self.history.len(), &values, g, why.as_deref());
                if let Some(why) = why {
                    self.rejected.push((self.history.len() - 1, why));
                }
                g
            }
        };
        g + outside
    }

    /// A coarse global scan: the misfit is rough on a fine scale (it is
    /// piecewise constant in the photon paths), so a simplex started far
    /// from the minimum can stall in a local one. The best of `from` and a
    /// stratified grid of `scan` points per parameter (at most 256 in all).
    fn scan(&mut self, from: (Vec<f64>, f64)) -> (Vec<f64>, f64) {
        let d = self.problem.params.len();
        let (mut from, mut from_misfit) = from;
        let m = scan_points(self.problem.opts.scan, d);
        if m > 1 {
            let total = m.pow(d as u32);
            for k in 0..total {
                let mut rem = k;
                let x: Vec<f64> = (0..d)
                    .map(|_| {
                        let i = rem % m;
                        rem /= m;
                        (i as f64 + 0.5) / m as f64
                    })
                    .collect();
                let fx = self.f(&x);
                if fx < from_misfit {
                    (from, from_misfit) = (x, fx);
                }
            }
        }
        (from, from_misfit)
    }

    /// One Nelder-Mead run from a fresh simplex at `from` (10 % of each
    /// range, away from the nearer bound): the last simplex, and whether
    /// the tolerances were met.
    fn nelder_mead(&mut self, from: &[f64], from_misfit: f64) -> (Simplex, bool) {
        let d = from.len();
        let opts = &self.problem.opts;
        let (tolerance, x_tolerance, max_evals) =
            (opts.tolerance, opts.x_tolerance, opts.max_evaluations);
        let mut simplex = vec![(from.to_vec(), from_misfit)];
        for j in 0..d {
            let mut x = from.to_vec();
            x[j] += if from[j] + 0.1 <= 1.0 { 0.1 } else { -0.1 };
            let fx = self.f(&x);
            simplex.push((x, fx));
        }
        loop {
            order(&mut simplex);
            let spread = simplex[d].1 - simplex[0].1;
            let size = simplex
                .iter()
                .flat_map(|(x, _)| x.iter().zip(&simplex[0].0).map(|(a, b)| (a - b).abs()))
                .fold(0.0, f64::max);
            if (spread <= tolerance && size <= x_tolerance) || size < 1e-12 {
                return (simplex, true);
            }
            if self.history.len() >= max_evals || self.calls >= 20 * max_evals + 100 {
                return (simplex, false);
            }
            self.step(&mut simplex);
        }
    }

    /// One Nelder-Mead step on `simplex` (ordered best first): reflection
    /// 1, expansion 2, contraction 1/2, else shrink 1/2 toward the best.
    fn step(&mut self, simplex: &mut Simplex) {
        let d = simplex.len() - 1;
        let centroid: Vec<f64> = (0..d)
            .map(|j| simplex[..d].iter().map(|(x, _)| x[j]).sum::<f64>() / d as f64)
            .collect();
        let worst = simplex[d].clone();
        let along = |t: f64| -> Vec<f64> {
            centroid
                .iter()
                .zip(&worst.0)
                .map(|(c, w)| c + t * (c - w))
                .collect()
        };
        let xr = along(1.0);
        let fr = self.f(&xr);
        if fr < simplex[0].1 {
            let xe = along(2.0);
            let fe = self.f(&xe);
            simplex[d] = if fe < fr { (xe, fe) } else { (xr, fr) };
            return;
        }
        if fr < simplex[d - 1].1 {
            simplex[d] = (xr, fr);
            return;
        }
        let (xc, fc, accept) = if fr < worst.1 {
            let xc = along(0.5);
            let fc = self.f(&xc);
            let ok = fc <= fr;
            (xc, fc, ok)
        } else {
            let xc = along(-0.5);
            let fc = self.f(&xc);
            let ok = fc < worst.1;
            (xc, fc, ok)
        };
        if accept {
            simplex[d] = (xc, fc);
            return;
        }
        let best = simplex[0].0.clone();
        for v in simplex.iter_mut().skip(1) {
            let x: Vec<f64> = best
                .iter()
                .zip(&v.0)
                .map(|(b, x)| b + 0.5 * (x - b))
                .collect();
            let fx = self.f(&x);
            *v = (x, fx);
        }
    }
}

impl Problem {
    /// As [`fit`](Self::fit), calling `observe(evaluation, values, misfit,
    /// rejected)` after every model run (`rejected`: why the scene rejected
    /// the values, the misfit then infinite).
    pub fn fit_observed(&self, observe: &mut Observer<'_>) -> Result<FitResult, FitError> {
        let x0: Vec<f64> = self
            .params
            .iter()
            .zip(self.current())
            .map(|(p, v)| p.unit(v).clamp(0.0, 1.0))
            .collect();
        let mut search = Search {
            problem: self,
            observe,
            history: Vec::new(),
            rejected: Vec::new(),
            calls: 0,
        };
        let start = search.values(&x0);
        // The start must be a valid scene: its rejection is the user's error.
        let start_model = self.model(&start).map_err(|e| e.0)?;
        let start_misfit = self.misfit_of(&start_model);
        search.history.push((start.clone(), start_misfit));
        (search.observe)(1, &start, start_misfit, None);
        let (mut from, mut from_misfit) = search.scan((x0, start_misfit));
        let mut restarts_done = 0;
        let (mut simplex, converged) = loop {
            let (mut simplex, converged) = search.nelder_mead(&from, from_misfit);
            order(&mut simplex);
            // Restart from the best point: Nelder-Mead can stall on a
            // degenerate simplex; a restart that gains nothing confirms it.
            let improved = simplex[0].1 < from_misfit - self.opts.tolerance;
            if !converged || restarts_done >= self.opts.restarts || (restarts_done > 0 && !improved)
            {
                break (simplex, converged);
            }
            restarts_done += 1;
            from = simplex[0].0.iter().map(|u| u.clamp(0.0, 1.0)).collect();
            let values = search.values(&from);
            from_misfit = search.recorded(&values).unwrap_or(simplex[0].1);
        };
        order(&mut simplex);
        let values = search.values(&simplex[0].0);
        let misfit = search.recorded(&values).unwrap_or(simplex[0].1);
        let model = self.model(&values).map_err(|e| e.0)?;
        Ok(FitResult {
            at_bounds: self.at_bounds(&values),
            values,
            misfit,
            start,
            start_misfit,
            evaluations: search.history.len(),
            converged,
            history: search.history,
            rejected: search.rejected,
            model,
        })
    }

    /// Per parameter, whether `values` ended on a bound: within the
    /// stopping box (`x_tolerance` of the range) of a bound counts as on it.
    fn at_bounds(&self, values: &[f64]) -> Vec<Bound> {
        let near = self.opts.x_tolerance.max(1e-9);
        self.params
            .iter()
            .zip(values)
            .map(|(p, &v)| {
                let u = p.unit(v);
                if u <= near {
                    Bound::Lower
                } else if u >= 1.0 - near {
                    Bound::Upper
                } else {
                    Bound::Inside
                }
            })
            .collect()
    }
}

/// Points per parameter of the coarse scan for `scan` requested and `d`
/// parameters: the largest `m <= scan` with `m^d <= 256` points in all, at
/// least 2; 0 (no scan) when `scan < 2`, `d = 0` or even `2^d` exceeds 256.
fn scan_points(scan: usize, d: usize) -> usize {
    if d == 0 {
        return 0;
    }
    let fits = |m: usize| {
        u32::try_from(d)
            .ok()
            .and_then(|d| m.checked_pow(d))
            .is_some_and(|t| t <= 256)
    };
    (2..=scan.min(256)).rev().find(|&m| fits(m)).unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scan_points_stay_within_256() {
        assert_eq!(scan_points(8, 1), 8);
        assert_eq!(scan_points(8, 2), 8);
        assert_eq!(scan_points(8, 3), 6);
        assert_eq!(scan_points(8, 8), 2);
        assert_eq!(scan_points(8, 9), 0);
        assert_eq!(scan_points(1, 1), 0);
        assert_eq!(scan_points(0, 1), 0);
        assert_eq!(scan_points(8, 0), 0);
        // Huge requests: no overflow, no count-down loop.
        assert_eq!(scan_points(usize::MAX, 1), 256);
        assert_eq!(scan_points(usize::MAX, 4), 4);
        assert_eq!(scan_points(usize::MAX, 100), 0);
    }
}
