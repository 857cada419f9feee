//! Soil Contact Model (Bekker-Wong pressure-sinkage, Janosi-Hanamoto shear) on a sparse grid with memory.
