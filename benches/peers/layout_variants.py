#!/usr/bin/env python3
"""Writes planar layouts posed as a user would pose them against the plastic layout LP, for
`layout_lp_compare.sh`: none of them is a shipped problem file or was used to tune anything.

Deck bridges (a pinned west anchor, an east anchor pinned or on a roller, 100 kN at every
lattice point of the deck, the truss in a band below or above it) over spans of 16-36 m,
depths of 2-6 m and lattice spacings of 1-3 m, one with compression twice as dear; and
cantilevers from a pinned abutment over a roller pier to a free end (50 kN per lattice point),
the truss above the deck. `linear` mass (steel, 250 MPa), `[connect] full`, default rounds and
solver settings.

Usage: python3 benches/peers/layout_variants.py OUT_DIR
       benches/peers/layout_lp_compare.sh OUT_DIR/*.toml
"""

import os
import sys

HEAD = """name = "{name}"
planar = true
max_force = 1e7          # N
min_length = 0.1         # m

[mass]
model = "linear"
sigma_t = 250e6          # Pa
sigma_c = {sigma_c:g}

"""


def anchor(name, x, roller=False):
    text = f'[[joint]]\nkind = "anchor"\nname = "{name}"\nat = [{x:.1f}, 0.0, 0.0]\n'
    if roller:
        text += 'support = "roller"\nreactions = [[0.0, 1.0, 0.0]]\n'
    return text + "\n"


def loads(name, x0, x1, count, newtons):
    return (f'[[joint]]\nkind = "load"\nname = "{name}"\nat = [{x0:.1f}, 0.0, 0.0]\n'
            f'to = [{x1:.1f}, 0.0, 0.0]\ncount = {count}\nforce = [0.0, {-newtons:g}, 0.0]\n\n')


def ground(x1, y0, y1, spacing):
    return (f'[ground]\nkind = "lattice"\nmin = [0.0, {y0:.1f}, 0.0]\nmax = [{x1:.1f}, {y1:.1f}, 0.0]\n'
            f'spacing = {spacing}\n\n[connect]\nfull = true\n\n')


def band(y0, y1):
    return (f'[[obstacle]]\nkind = "half_space"\npoint = [0.0, {y0:.1f}, 0.0]\nnormal = [0.0, 1.0, 0.0]\n\n'
            f'[[obstacle]]\nkind = "half_space"\npoint = [0.0, {y1:.1f}, 0.0]\nnormal = [0.0, -1.0, 0.0]\n')


def layouts():
    # (span m, depth m, spacing m, truss below the deck, east roller, compression strength Pa)
    decks = [(16, 2, 2.0, True, True, 250e6), (20, 4, 2.0, True, True, 250e6),
             (28, 4, 2.0, False, True, 250e6), (36, 6, 3.0, True, True, 250e6),
             (18, 3, 1.5, False, False, 250e6), (24, 4, 2.0, True, True, 125e6),
             (30, 5, 2.5, False, True, 250e6), (20, 2, 1.0, True, True, 250e6)]
    for i, (span, depth, spacing, below, roller, sigma_c) in enumerate(decks):
        name = f"deck_{i}"
        y0, y1 = (-depth, -spacing) if below else (spacing, depth)
        text = HEAD.format(name=name, sigma_c=sigma_c)
        text += anchor("west", 0.0) + anchor("east", span, roller)
        text += loads("deck", spacing, span - spacing, round(span / spacing) - 1, 1e5)
        text += ground(span, y0, y1, spacing)
        text += band(-depth, 0.0) if below else band(0.0, depth)
        yield name, text
    # (pier m, free end m, depth m, spacing m); abutment at 0
    piers = [(16, 24, 4, 2.0), (12, 20, 3, 2.0), (24, 30, 4, 2.0), (10, 18, 4, 2.0)]
    for i, (pier, end, depth, spacing) in enumerate(piers):
        name = f"pier_{i}"
        text = HEAD.format(name=name, sigma_c=250e6)
        text += anchor("abutment", 0.0) + anchor("pier", pier, True)
        text += loads("span", spacing, pier - spacing, round(pier / spacing) - 1, 5e4)
        text += loads("arm", pier + spacing, end, round((end - pier) / spacing), 5e4)
        text += ground(end, spacing, depth, spacing) + band(0.0, depth)
        yield name, text


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    for name, text in layouts():
        with open(os.path.join(out, f"{name}.toml"), "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
