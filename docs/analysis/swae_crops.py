"""Measurements on the release's 1000 SWAE training crops behind BENCHMARKS.md's "SWAE v3" paragraphs.

Run: python3 -m venv /tmp/np && /tmp/np/bin/pip install numpy pillow &&
     VB_RELEASE_DIR=../shared/verti-bench-release /tmp/np/bin/python docs/analysis/swae_crops.py

Prints (1) the 32-px grid: mean |vertical| and |horizontal| difference per image row / column over all crops and
the strongest periods of those profiles; (2) the radially averaged power by wavelength band; (3) the residual of
a 64-component PCA (fitted on the first 900 crops, as `vb terrain eval` does on its 900 training crops) against
the PCA mean's local slope, the residual's |gradient| mean / rms ratio (0.886 for a Gaussian field) and its
kurtosis (3 for a Gaussian); (4) the
mean, p50 and p95 slope (degrees, 1 m pixels, 50.48 m for a normalised +1, as `vb terrain eval`) of crops and of
PCA maps from training codes, Gaussian codes or codes with the training codes' marginals, with and without the
true residual of another crop added, or a Gaussian texture with the residuals' mean periodogram, or that texture
quantile-mapped onto the residuals' marginal law (as v3's observation model): where the samples' excess mean
slope comes from; (5) the same texture as a Gaussian scale mixture (v4's observation model): its kurtosis, slope
ratio and the samples' slopes. FULL_SCALE=11.32 measures at v3's committed scale (default 50.48 m, v1's).
"""
import os

import numpy as np
from PIL import Image

d = os.path.join(os.environ["VB_RELEASE_DIR"], "BenchMaps", "elev_maps")
gray = np.stack([np.asarray(Image.open(f"{d}/{i}.bmp").convert("L"), dtype=np.float64) for i in range(1, 1001)])
X = gray / 255 * 2 - 1
rng = np.random.default_rng(0)

# (1) the grid
gy = np.abs(np.diff(gray, axis=1)).mean(axis=(0, 2))
gx = np.abs(np.diff(gray, axis=2)).mean(axis=(0, 1))
print("mean |dy| per row, every 4th row (gray levels):", np.round(gy[::4], 2))
print("mean |dx| per column, every 4th column:", np.round(gx[::4], 2))
for name, p in [("rows", gy), ("columns", gx)]:
    spec = np.abs(np.fft.rfft(p - p.mean()))
    top = [k for k in np.argsort(spec)[::-1] if k > 0][:3]
    print(f"strongest periods over {name}:", [round(len(p) / k, 1) for k in top], "px")

# (2) power by wavelength
P = (np.abs(np.fft.fft2(X - X.mean((1, 2), keepdims=True))) ** 2).mean(0)
k = np.sqrt(np.fft.fftfreq(128)[:, None] ** 2 + np.fft.fftfreq(128)[None, :] ** 2)
for lo, hi in [(0, 0.05), (0.05, 0.1), (0.1, 0.2), (0.2, 0.8)]:
    m = (k > lo) & (k <= hi)
    print(f"power at {lo}-{hi} cycles/px: {P[m].sum() / P.sum():.3f}")

# (3) PCA residual
F = X.reshape(1000, -1)
mu = F[:900].mean(0)
C = F - mu
_, _, Vt = np.linalg.svd(C[:900], full_matrices=False)
B = Vt[:64]
R = (C @ B.T) @ B + mu
res = (F - R).reshape(-1, 128, 128)
M = R.reshape(-1, 128, 128)


def grad(a):
    g_y = np.zeros_like(a)
    g_x = np.zeros_like(a)
    g_y[:, 1:-1] = (a[:, 2:] - a[:, :-2]) / 2
    g_x[:, :, 1:-1] = (a[:, :, 2:] - a[:, :, :-2]) / 2
    return np.sqrt(g_x**2 + g_y**2)


gm = grad(M)[:, 2:-2, 2:-2].ravel()
r2 = (res[:, 2:-2, 2:-2] ** 2).ravel()
q = np.quantile(gm, np.linspace(0, 1, 11))
print("residual rms by decile of the PCA map's local slope:")
for i in range(10):
    m = (gm >= q[i]) & (gm <= q[i + 1])
    print(f"  {q[i]:.4f}-{q[i + 1]:.4f}: {np.sqrt(r2[m].mean()):.4f}")
gr = grad(res)[:, 2:-2, 2:-2].ravel()
print("residual |grad| mean / rms:", round(gr.mean() / np.sqrt((gr**2).mean()), 3), "(Gaussian field: 0.886)")
r = res.ravel()
print("residual kurtosis:", round(((r - r.mean()) ** 4).mean() / r.var() ** 2, 2), "(Gaussian: 3)")

# (4) where the excess slope comes from
FS = float(os.environ.get("FULL_SCALE", "50.48"))


def slopes(maps):
    h = (maps + 1) / 2 * FS
    sy = (h[:, 2:, 1:-1] - h[:, :-2, 1:-1]) / 2
    sx = (h[:, 1:-1, 2:] - h[:, 1:-1, :-2]) / 2
    s = np.degrees(np.arctan(np.sqrt(sx**2 + sy**2)))
    return np.round([s.mean(), np.percentile(s, 50), np.percentile(s, 95)], 1)


n = 300
codes = C[:900] @ B.T
z_train = codes[rng.choice(900, n)]
z_gauss = rng.standard_normal((n, 64)) * codes.std(0)
z_marg = np.stack([rng.choice(codes[:, j], n) for j in range(64)], 1)
texture = res[rng.choice(900, n)]
print("slope mean / p50 / p95, deg: crops", slopes(X[:n]))
for name, z in [("training codes", z_train), ("Gaussian codes", z_gauss), ("codes with training marginals", z_marg)]:
    maps = (z @ B + mu).reshape(-1, 128, 128)
    print(f"  PCA map of {name}: {slopes(maps)}; plus another crop's true residual: {slopes(maps + texture)}")
P_res = (np.abs(np.fft.fft2(res[:900])) ** 2).mean(0)
gauss = np.real(np.fft.ifft2(np.fft.fft2(rng.standard_normal((n, 128, 128))) * np.sqrt(P_res))) / 128
probs = np.linspace(0, 1, 1001)[1:-1]
mapped = np.interp(gauss, np.quantile(gauss.ravel(), probs), np.quantile(res[:900].ravel(), probs))
maps = (z_gauss @ B + mu).reshape(-1, 128, 128)
print(f"  PCA map of Gaussian codes plus Gaussian texture: {slopes(maps + gauss)}; quantile-mapped: {slopes(maps + mapped)}")

# (5) the texture as a Gaussian scale mixture (v4's observation model): e = s g with s = exp(sigma a - sigma^2),
# a a smooth unit Gaussian field (Gaussian kernel of std 6 px), sigma from the residuals' kurtosis (3 exp(4 sigma^2)).
sigma = np.sqrt(np.log(((res[:900] - res[:900].mean()) ** 4).mean() / res[:900].var() ** 2 / 3) / 4)
freq2 = np.fft.fftfreq(128)[:, None] ** 2 + np.fft.fftfreq(128)[None, :] ** 2
print(f"log-amplitude sigma from the kurtosis: {sigma:.3f}")
for std_px in [2, 6, 16]:
    a = np.real(np.fft.ifft2(np.fft.fft2(rng.standard_normal((n, 128, 128))) * np.exp(-2 * np.pi**2 * std_px**2 * freq2)))
    a /= a.std()
    mixture = np.exp(sigma * a - sigma**2) * gauss
    g = np.hypot(*np.gradient(mixture, axis=(1, 2)))[:, 2:-2, 2:-2]
    m = mixture.ravel()
    print(
        f"  amplitude smoothed over {std_px} px: kurtosis {((m - m.mean()) ** 4).mean() / m.var() ** 2:.2f}, "
        f"|grad| mean / rms {g.mean() / np.sqrt((g**2).mean()):.3f}; PCA map of Gaussian codes plus it: "
        f"{slopes(maps + mixture)}, quantile-mapped: {slopes(maps + np.interp(mixture, np.quantile(mixture.ravel(), probs), np.quantile(res[:900].ravel(), probs)))}"
    )
