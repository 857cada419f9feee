//! Adam (Kingma and Ba, "Adam: A Method for Stochastic Optimization", ICLR 2015, Algorithm 1) over the model's
//! variables by name, with its moments and step count saved beside a checkpoint, so a training run resumes where
//! its last completed epoch left it (candle's own AdamW keeps its state private).

use crate::SwaeError;
use candle_core::{DType, Device, Tensor, Var};
use candle_nn::VarMap;
use std::collections::HashMap;
use std::path::Path;

/// Adam's constants (the paper's defaults).
pub const BETA1: f64 = 0.9;
pub const BETA2: f64 = 0.999;
pub const EPSILON: f64 = 1e-8;

/// Adam over every trainable variable of a [`VarMap`], in name order.
pub struct Adam {
    names: Vec<String>,
    vars: Vec<Var>,
    m: Vec<Tensor>,
    v: Vec<Tensor>,
    /// Updates done so far (the bias corrections use it).
    pub step: u64,
    pub lr: f64,
}

impl Adam {
    /// Fresh state (zero moments) for the variables of `varmap` except scalars and those `frozen` names.
    pub fn new(varmap: &VarMap, lr: f64, frozen: impl Fn(&str) -> bool) -> Result<Adam, SwaeError> {
        let data = varmap.data().lock().expect("varmap lock");
        let mut names: Vec<String> = data
            .iter()
            .filter(|(n, v)| !v.dims().is_empty() && !frozen(n))
            .map(|(n, _)| n.clone())
            .collect();
        names.sort();
        let vars: Vec<Var> = names.iter().map(|n| data[n].clone()).collect();
        let zeros = |v: &Var| Tensor::zeros(v.dims(), DType::F32, &Device::Cpu);
        let m = vars.iter().map(zeros).collect::<Result<Vec<_>, _>>()?;
        let v = vars.iter().map(zeros).collect::<Result<Vec<_>, _>>()?;
        Ok(Adam {
            names,
            vars,
            m,
            v,
            step: 0,
            lr,
        })
    }

    /// Back-propagates `loss` and updates every variable it depends on (BatchNorm's running statistics get no
    /// gradient and are left to BatchNorm).
    pub fn backward_step(&mut self, loss: &Tensor) -> Result<(), SwaeError> {
        let grads = loss.backward()?;
        self.step += 1;
        let t = self.step as i32;
        let (c1, c2) = (1.0 - BETA1.powi(t), 1.0 - BETA2.powi(t));
        for i in 0..self.vars.len() {
            let Some(g) = grads.get(&self.vars[i]) else {
                continue;
            };
            // Detached: the moments are running sums over every step, and a moment that tracked its operands
            // would hold every earlier step's gradient graph (a 6-epoch run grew to 24 GB and was killed).
            let g = g.detach();
            let g = &g;
            let m = ((&self.m[i] * BETA1)? + (g * (1.0 - BETA1))?)?;
            let v = ((&self.v[i] * BETA2)? + (g.sqr()? * (1.0 - BETA2))?)?;
            let denom = ((&v / c2)?.sqrt()? + EPSILON)?;
            let update = ((&m / c1)?.div(&denom)? * self.lr)?;
            self.vars[i].set(&(self.vars[i].as_tensor() - update)?)?;
            self.m[i] = m.detach();
            self.v[i] = v.detach();
        }
        Ok(())
    }

    /// Writes the moments as safetensors (`m.<name>`, `v.<name>`).
    pub fn save(&self, path: &Path) -> Result<(), SwaeError> {
        let mut map: HashMap<String, Tensor> = HashMap::new();
        for (i, name) in self.names.iter().enumerate() {
            map.insert(format!("m.{name}"), self.m[i].clone());
            map.insert(format!("v.{name}"), self.v[i].clone());
        }
        candle_core::safetensors::save(&map, path).map_err(|e| SwaeError::Weights {
            path: path.into(),
            message: e.to_string(),
        })
    }

    /// Reads moments written by [`Adam::save`] for the same variables; `step` comes from the training state.
    pub fn load(&mut self, path: &Path, step: u64) -> Result<(), SwaeError> {
        let bad = |message: String| SwaeError::Weights {
            path: path.into(),
            message,
        };
        let mut map =
            candle_core::safetensors::load(path, &Device::Cpu).map_err(|e| bad(e.to_string()))?;
        for (i, name) in self.names.iter().enumerate() {
            for (key, slot) in [("m", &mut self.m[i]), ("v", &mut self.v[i])] {
                let t = map
                    .remove(&format!("{key}.{name}"))
                    .ok_or_else(|| bad(format!("missing optimiser state `{key}.{name}`")))?;
                if t.dims() != slot.dims() {
                    return Err(bad(format!(
                        "optimiser state `{key}.{name}` has shape {:?}, the model {:?}",
                        t.dims(),
                        slot.dims()
                    )));
                }
                *slot = t.to_dtype(DType::F32)?;
            }
        }
        self.step = step;
        Ok(())
    }
}
