#!/usr/bin/env python3
"""Guided over unguided relMSE less the reference's variance, at the images' size
and box-downsampled by an integer factor (docs/guiding.md, "Small images").

  relmse-ratio.py REF.exr REF.var.exr FACTOR GUIDED.exr... -- UNGUIDED.exr...
  relmse-ratio.py --downsample IN.exr IN.var.exr FACTOR OUT.exr OUT.var.exr

Each image's relMSE is the mean over pixels and channels of ((x - r)^2 - v) /
(r^2 + 0.01), as `rlpt compare --reference-variance` computes it. Downsampled,
a pixel is the mean of FACTOR x FACTOR pixels and the reference's variance the
mean of theirs over FACTOR^2 (independent estimates). Where IMAGE.var.exr exists
(`rlpt render --variance`), the expected relMSE from the image's own variance is
printed too: far less noisy than one image's squared error. The ratio is of the
means over the images given. Needs numpy and the OpenEXR bindings.
"""
import sys

import Imath
import numpy as np
import OpenEXR

FLOAT = Imath.PixelType(Imath.PixelType.FLOAT)


def load(path):
    f = OpenEXR.InputFile(path)
    dw = f.header()['dataWindow']
    w, h = dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1
    return np.stack([np.frombuffer(f.channel(c, FLOAT), dtype=np.float32).reshape(h, w) for c in 'RGB'],
                    -1).astype(np.float64)


def save(path, img):
    h, w, _ = img.shape
    header = OpenEXR.Header(w, h)
    header['channels'] = {c: Imath.Channel(FLOAT) for c in 'RGB'}
    out = OpenEXR.OutputFile(path, header)
    out.writePixels({c: img[..., i].astype(np.float32).tobytes() for i, c in enumerate('RGB')})
    out.close()


def down(img, f):
    h, w, c = img.shape
    if h % f or w % f:
        raise SystemExit(f'{w}x{h} is not a multiple of {f}')
    return img.reshape(h // f, f, w // f, f, c).mean(axis=(1, 3))


def down_var(var, f):
    return down(var, f) / (f * f)


def rel_mse(x, r, v):
    return (((x - r) ** 2 - v) / (r * r + 0.01)).mean()


def errors(path, ref, ref_var, f):
    x = load(path)
    full = rel_mse(x, ref, ref_var)
    small = rel_mse(down(x, f), down(ref, f), down_var(ref_var, f))
    try:
        xv = load(path[:-4] + '.var.exr')
        expected = ((xv / (ref * ref + 0.01)).mean(), (down_var(xv, f) / (down(ref, f) ** 2 + 0.01)).mean())
    except OSError:
        expected = (np.nan, np.nan)
    return np.array([full, small, *expected])


def main(args):
    if args[:1] == ['--downsample'] and len(args) == 6:
        f = int(args[3])
        save(args[4], down(load(args[1]), f))
        save(args[5], down_var(load(args[2]), f))
        return
    if len(args) < 6 or '--' not in args[3:]:
        raise SystemExit(__doc__)
    ref, ref_var, f = load(args[0]), load(args[1]), int(args[2])
    k = args.index('--')
    means = []
    for name, paths in (('guided', args[3:k]), ('unguided', args[k + 1:])):
        rows = []
        for p in paths:
            e = errors(p, ref, ref_var, f)
            print(f'{name:8s} {p}: relMSE {e[0]:.4e}, downsampled {e[1]:.4e}; expected {e[2]:.4e}, {e[3]:.4e}')
            rows.append(e)
        means.append(np.mean(rows, axis=0))
    g, u = means
    print(f'guided / unguided: {g[0] / u[0]:.3f}, downsampled by {f} {g[1] / u[1]:.3f}; '
          f'expected {g[2] / u[2]:.3f}, downsampled {g[3] / u[3]:.3f}')


if __name__ == '__main__':
    main(sys.argv[1:])
