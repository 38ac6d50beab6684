#!/usr/bin/python3
"""Reference SSIM and PSNR values for test_metrics.cpp, computed with an
independent implementation: scikit-image (Debian package python3-skimage),
with Wang et al.'s settings. The test images are defined by integer
formulas that test_metrics.cpp repeats exactly. Run it to regenerate the
numbers pasted into the test:  /usr/bin/python3 tests/eval/reference_metrics.py
(Debian's interpreter: the one that sees python3-skimage).
"""
import numpy as np
from skimage.metrics import peak_signal_noise_ratio, structural_similarity

W, H = 64, 48


def base():
    a = np.zeros((H, W), dtype=np.int64)
    for y in range(H):
        for x in range(W):
            a[y, x] = (x * 7 + y * 13 + ((x * y) % 17) * 5) % 256
    return a


def noisy(a):
    state = 12345
    b = a.copy()
    for y in range(H):
        for x in range(W):
            state = (state * 1103515245 + 12345) % (1 << 31)
            b[y, x] = min(255, max(0, a[y, x] + (state >> 16) % 41 - 20))
    return b


def blurred(a):
    b = a.copy()
    for y in range(H):
        for x in range(W):
            s = 0
            for dy in (-1, 0, 1):
                for dx in (-1, 0, 1):
                    s += a[min(H - 1, max(0, y + dy)), min(W - 1, max(0, x + dx))]
            b[y, x] = s // 9
    return b


def shifted(a):
    b = a.copy()
    b[:, 1:] = a[:, :-1]
    return b


def rescaled(a):
    return (a * 4 + 100) // 5


a = base()
for name, b in (("noisy", noisy(a)), ("blurred", blurred(a)), ("shifted", shifted(a)), ("rescaled", rescaled(a))):
    ssim = structural_similarity(a.astype(np.float64), b.astype(np.float64), data_range=255,
                                 gaussian_weights=True, sigma=1.5, use_sample_covariance=False)
    psnr = peak_signal_noise_ratio(a.astype(np.float64), b.astype(np.float64), data_range=255)
    print(f"{name}: ssim {ssim:.10f} psnr {psnr:.10f}")
