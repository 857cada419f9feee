//! Sliced-Wasserstein autoencoder terrain generator (candle): training, decoding, calibration.
