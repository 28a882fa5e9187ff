#!/usr/bin/env python3
"""Write src/bsdf/named_conductors.rs: the RGB `eta` and `k` that Mitsuba 3's
RGB variants give each named conductor (`<string name="material" value="Au"/>`).

Mitsuba reads the material's spectral index of refraction (its
resources/data/ior/*.spd, the data pbrt also ships) and, in an RGB variant,
turns each spectrum into one RGB value. This script asks Mitsuba itself
(`scalar_rgb`) for those values, so the table is exactly what a Mitsuba RGB
render of the same file uses. The names are the presets of Mitsuba 3's
conductor documentation (its `conductor-ior-list` table).

Usage: pip install mitsuba==3.9.1; python3 scripts/mitsuba_named_conductors.py; cargo fmt
"""
import os

import mitsuba as mi

NAMES = """a-C Na_palik Ag Nb Nb_palik Al Ni_palik AlAs AlAs_palik Rh Rh_palik
AlSb AlSb_palik Se Se_palik Au SiC SiC_palik Be Be_palik SnTe SnTe_palik Cr
Ta Ta_palik CsI CsI_palik Te Te_palik Cu Cu_palik ThF4 ThF4_palik Cu2O
Cu2O_palik TiC TiC_palik CuO CuO_palik TiN TiN_palik d-C d-C_palik TiO2
TiO2_palik Hg Hg_palik VC VC_palik HgTe HgTe_palik V_palik Ir Ir_palik VN
VN_palik K K_palik W Li Li_palik MgO MgO_palik Mo Mo_palik""".split()


def main():
    mi.set_variant("scalar_rgb")
    rows = []
    for name in sorted(NAMES, key=str.lower):
        params = mi.traverse(mi.load_dict({"type": "conductor", "material": name}))
        eta = [float(v) for v in params["eta.value"]]
        k = [float(v) for v in params["k.value"]]
        rows.append((name, eta, k))
    here = os.path.dirname(os.path.abspath(__file__))
    out = os.path.join(here, "..", "src", "bsdf", "named_conductors.rs")
    f32 = lambda v: f"{v:.9e}"
    with open(out, "w") as f:
        f.write(
            "//! Mitsuba 3's named conductors (`<string name=\"material\" value=\"Au\"/>`):\n"
            "//! the RGB index of refraction `eta` and absorption `k` that Mitsuba's\n"
            f"//! RGB variants give each, as Mitsuba {mi.__version__} (`scalar_rgb`) reports them.\n"
            "//! Written by `scripts/mitsuba_named_conductors.py`; do not edit.\n\n"
            "/// `(name, eta, k)`, sorted by name ignoring case.\n"
            "#[allow(clippy::excessive_precision)]\n"
            "pub const NAMED_CONDUCTORS: &[(&str, [f32; 3], [f32; 3])] = &[\n"
        )
        for name, eta, k in rows:
            f.write(
                f"    (\"{name}\", [{', '.join(map(f32, eta))}], [{', '.join(map(f32, k))}]),\n"
            )
        f.write("];\n")
    print(f"{len(rows)} conductors -> {os.path.normpath(out)}")


if __name__ == "__main__":
    main()
