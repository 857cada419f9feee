//! `exp` and `tanh` from `+ - * /` only, so the decoder's output does not depend on the platform's libm.

/// `e^x` from `+ - * /` only (range reduction by ln 2, degree-16 Taylor polynomial, exact power of two), accurate
/// to a few ulp and identical on every IEEE-754 machine.
pub fn exp(x: f64) -> f64 {
    if x > 700.0 {
        return f64::INFINITY;
    }
    if x < -700.0 {
        return 0.0;
    }
    const LN2: f64 = std::f64::consts::LN_2;
    let k = (x / LN2).round();
    let r = x - k * LN2;
    let mut term = 1.0;
    let mut sum = 1.0;
    for i in 1..=16 {
        term = term * r / i as f64;
        sum += term;
    }
    sum * f64::from_bits(((k as i64 + 1023) as u64) << 52)
}

/// `tanh` from [`exp`]: `1 - 2 / (e^{2x} + 1)`, odd-symmetric.
pub fn tanh(x: f64) -> f64 {
    let a = x.abs();
    let t = if a > 20.0 {
        1.0
    } else if a < 1e-3 {
        // Avoid cancellation near 0: x - x^3/3 + 2x^5/15.
        let a2 = a * a;
        a * (1.0 - a2 / 3.0 + 2.0 * a2 * a2 / 15.0)
    } else {
        1.0 - 2.0 / (exp(2.0 * a) + 1.0)
    };
    if x < 0.0 {
        -t
    } else {
        t
    }
}
