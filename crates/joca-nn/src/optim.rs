//! Adam and AdamW written out over a `VarStore`, so that their state (step count, first and second
//! moments) can be checkpointed and restored exactly; tch's built-in optimisers keep it hidden.
//!
//! Update for a parameter `p` with gradient `g` at step `t` (Kingma & Ba; Loshchilov & Hutter):
//!
//! ```text
//! m ← β1·m + (1−β1)·g          v ← β2·v + (1−β2)·g²
//! p ← p − lr·wd·p              (AdamW only: decoupled weight decay)
//! p ← p − lr/(1−β1ᵗ) · m / (√(v/(1−β2ᵗ)) + ε)
//! ```

use crate::NnError;
use serde::{Deserialize, Serialize};
use std::path::Path;
use tch::nn::VarStore;
use tch::{Kind, Tensor};

/// Optimiser settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdamConfig {
    /// Learning rate.
    pub lr: f64,
    /// Weight decay, decoupled (AdamW) when non-zero.
    pub weight_decay: f64,
    /// First-moment decay.
    pub beta1: f64,
    /// Second-moment decay.
    pub beta2: f64,
    /// Denominator guard.
    pub eps: f64,
}

impl AdamConfig {
    /// AdamW with the paper's detector settings: lr 1e-4, weight decay 1e-6.
    pub const DETECTOR: AdamConfig =
        AdamConfig { lr: 1e-4, weight_decay: 1e-6, beta1: 0.9, beta2: 0.999, eps: 1e-8 };
    /// Adam with the paper's ACC settings: lr 1e-5.
    pub const ACC: AdamConfig =
        AdamConfig { lr: 1e-5, weight_decay: 0.0, beta1: 0.9, beta2: 0.999, eps: 1e-8 };
}

/// Adam / AdamW over the trainable variables of a `VarStore`.
#[derive(Debug)]
pub struct Adam {
    config: AdamConfig,
    step: i64,
    names: Vec<String>,
    params: Vec<Tensor>,
    m: Vec<Tensor>,
    v: Vec<Tensor>,
}

impl Adam {
    /// An optimiser for every trainable variable of `vs`, in name order.
    ///
    /// Every variable gets a zero gradient here, so that a step treats a variable the loss did
    /// not reach as having gradient zero (its moments decay and it still moves), from the first
    /// step on. Otherwise the rule would depend on history: a variable whose gradient was never
    /// allocated is skipped, one whose gradient was allocated and zeroed is not — and a run
    /// resumed from a checkpoint (fresh, unallocated gradients) would train differently from
    /// the run it continues.
    pub fn new(vs: &VarStore, config: AdamConfig) -> Self {
        let mut vars: Vec<(String, Tensor)> =
            vs.variables().into_iter().filter(|(_, t)| t.requires_grad()).collect();
        vars.sort_by(|a, b| a.0.cmp(&b.0));
        for (_, t) in &vars {
            if !t.grad().defined() {
                (t * 0.0).sum(Kind::Float).backward();
            }
        }
        let m = vars.iter().map(|(_, t)| t.zeros_like()).collect();
        let v = vars.iter().map(|(_, t)| t.zeros_like()).collect();
        let (names, params) = vars.into_iter().unzip();
        Self { config, step: 0, names, params, m, v }
    }

    /// Settings.
    pub fn config(&self) -> AdamConfig {
        self.config
    }

    /// Changes the learning rate (schedules).
    pub fn set_lr(&mut self, lr: f64) {
        self.config.lr = lr;
    }

    /// Steps taken.
    pub fn steps(&self) -> i64 {
        self.step
    }

    /// Clears every gradient.
    pub fn zero_grad(&mut self) {
        for p in &mut self.params {
            let mut g = p.grad();
            if g.defined() {
                let _ = g.zero_();
            }
        }
    }

    /// Applies one update from the current gradients.
    pub fn step(&mut self) {
        let _guard = tch::no_grad_guard();
        self.step += 1;
        let c = self.config;
        let bc1 = 1.0 - c.beta1.powi(self.step as i32);
        let bc2 = 1.0 - c.beta2.powi(self.step as i32);
        for ((p, m), v) in self.params.iter_mut().zip(&mut self.m).zip(&mut self.v) {
            let g = p.grad();
            if !g.defined() {
                continue;
            }
            // The same update in few in-place kernels (it is memory-bound): m and v by lerp,
            // then p += m / d with d = −(bc1/lr)·(√v/√bc2 + ε).
            let _ = m.lerp_(&g, 1.0 - c.beta1);
            let _ = v.lerp_(&(&g * &g), 1.0 - c.beta2);
            if c.lr == 0.0 {
                continue; // nothing moves (and d would divide by 0)
            }
            if c.weight_decay != 0.0 {
                let _ = p.g_mul_scalar_(1.0 - c.lr * c.weight_decay);
            }
            let mut denom = v.sqrt();
            let _ = denom.g_mul_scalar_(-bc1 / (c.lr * bc2.sqrt()));
            let _ = denom.g_add_scalar_(-bc1 / c.lr * c.eps);
            let _ = p.addcdiv_(m, &denom);
        }
    }

    /// Writes the state (step, moments) to a safetensors file.
    pub fn save(&self, path: &Path) -> Result<(), NnError> {
        let mut tensors: Vec<(String, Tensor)> =
            vec![("step".to_owned(), Tensor::from_slice(&[self.step]))];
        for ((name, m), v) in self.names.iter().zip(&self.m).zip(&self.v) {
            tensors.push((format!("m.{name}"), m.shallow_clone()));
            tensors.push((format!("v.{name}"), v.shallow_clone()));
        }
        Tensor::write_safetensors(&tensors, path)?;
        Ok(())
    }

    /// Restores a state written by [`Adam::save`] for the same variables.
    pub fn load(&mut self, path: &Path) -> Result<(), NnError> {
        let err = |reason: String| NnError::Weights { path: path.display().to_string(), reason };
        let size = std::fs::metadata(path).map_err(|e| err(e.to_string()))?.len();
        if size > crate::weights::MAX_WEIGHTS_BYTES {
            return Err(err(format!("{size} bytes: larger than any joca optimiser state")));
        }
        let file: std::collections::HashMap<String, Tensor> =
            Tensor::read_safetensors(path)?.into_iter().collect();
        let step = file.get("step").ok_or_else(|| err("no tensor `step`".into()))?;
        let _guard = tch::no_grad_guard();
        for ((name, m), v) in self.names.iter().zip(&mut self.m).zip(&mut self.v) {
            for (prefix, slot) in [("m", &mut *m), ("v", &mut *v)] {
                let key = format!("{prefix}.{name}");
                let t = file
                    .get(&key)
                    .ok_or_else(|| err(format!("optimiser state has no tensor `{key}`")))?;
                crate::weights::check_tensor(&key, t, slot).map_err(err)?;
                if t.size() != slot.size() {
                    return Err(err(format!(
                        "`{key}` has shape {:?}, the model needs {:?}",
                        t.size(),
                        slot.size()
                    )));
                }
                slot.copy_(t);
            }
        }
        self.step = step.int64_value(&[0]);
        Ok(())
    }
}

/// Sum of squares of every gradient (for NaN checks and logging).
pub fn grad_norm(vs: &VarStore) -> f64 {
    let _guard = tch::no_grad_guard();
    vs.trainable_variables()
        .iter()
        .map(|p| {
            let g = p.grad();
            if g.defined() {
                g.pow_tensor_scalar(2.0).sum(Kind::Double).double_value(&[])
            } else {
                0.0
            }
        })
        .sum::<f64>()
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three AdamW steps against the update written out in f64 (Loshchilov & Hutter's decoupled
    /// weight decay, bias-corrected moments), with gradients of both signs and a zero one.
    #[test]
    fn adamw_follows_the_closed_form() {
        let _serial = crate::torch_serial();
        let c = AdamConfig { lr: 1e-2, weight_decay: 0.1, beta1: 0.9, beta2: 0.999, eps: 1e-8 };
        let vs = VarStore::new(tch::Device::Cpu);
        let p = vs.root().var_copy("p", &Tensor::from_slice(&[1.0f32, -2.0, 0.5]));
        let mut adam = Adam::new(&vs, c);
        let grads = [[0.3f64, -1.0, 0.0], [0.1, 2.0, 0.0], [-0.5, 0.25, 0.0]];
        let (mut want, mut m, mut v) = ([1.0f64, -2.0, 0.5], [0.0f64; 3], [0.0f64; 3]);
        for (t, g) in grads.iter().enumerate() {
            adam.zero_grad();
            let gt = Tensor::from_slice(&g.map(|x| x as f32));
            (&p * &gt).sum(Kind::Float).backward();
            adam.step();
            let t = t as i32 + 1;
            for i in 0..3 {
                m[i] = c.beta1 * m[i] + (1.0 - c.beta1) * g[i];
                v[i] = c.beta2 * v[i] + (1.0 - c.beta2) * g[i] * g[i];
                want[i] *= 1.0 - c.lr * c.weight_decay;
                let m_hat = m[i] / (1.0 - c.beta1.powi(t));
                let v_hat = v[i] / (1.0 - c.beta2.powi(t));
                want[i] -= c.lr * m_hat / (v_hat.sqrt() + c.eps);
            }
            for (i, w) in want.iter().enumerate() {
                let got = p.double_value(&[i as i64]);
                assert!((got - w).abs() < 1e-6, "step {t}, p[{i}]: {got} vs {w}");
            }
        }
        // A learning rate of 0 moves nothing.
        let before = Vec::<f32>::try_from(&p).unwrap();
        adam.set_lr(0.0);
        adam.zero_grad();
        (&p * 3.0).sum(Kind::Float).backward();
        adam.step();
        assert_eq!(Vec::<f32>::try_from(&p).unwrap(), before);
    }
}
