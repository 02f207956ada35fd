"""``granpack limits``: the model's own e_min and e_max for a scene."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from .._console import Console
from .._contact_model import model_record
from .._validate import check_outputs

HELP = "e_min and e_max of the model for a scene, over packs"
DESCRIPTION = (
    "For each of --packs streams, generates the scene with every layer jammed at each "
    "deposition friction of the grid (0, 0.1, 0.2, 0.5, 1 and the material's own), each "
    "brought back to the material's friction, settled and, when the scene consolidates, "
    "consolidated, and (when it consolidates) the recipe's sample with its friction "
    "lowered to zero under the servo; e_min is the densest of these, e_max the loosest. "
    "Prints the mean void ratio of each end with its standard deviation "
    "(granpack.void_ratio_limits; docs/density.md)."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    p = parser
    p.add_argument("scene", metavar="SCENE", help="preset name (4.1, 4.2, 4.3, 4.4) or TOML file")
    p.add_argument("--packs", type=int, default=5, help="packs per end (default 5)")
    p.add_argument("--fast", action="store_true", help="the fast settings (PackScene.fast())")
    p.add_argument("--json", type=Path, default=None, help="also write the limits to this file")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")


def run(args: argparse.Namespace, console: Console) -> int:
    from .._files import atomic_write
    from .._outputs import unsettled_as_notes
    from ..density import void_ratio_limits
    from ..scene import PRESETS
    from .generate import _scene_from_arg

    if args.json is not None:
        # the scene's own file is an input: --json naming it would overwrite the scene
        scene_file = [Path(args.scene)] if args.scene not in PRESETS else []
        check_outputs([args.json], scene_file, parameter="--json")
    scene, name = _scene_from_arg(args.scene)
    if args.fast:
        scene = scene.fast()
    with unsettled_as_notes(console):
        lim = void_ratio_limits(
            scene,
            packs=args.packs,
            progress=lambda row: console.say(
                f"  stream {row['stream']}, {_what(row)}: phi {row['phi']:.4f}, "
                f"e {row['void_ratio']:.4f} ({row['seconds']:.1f} s)"
            ),
        )
    console.say(
        f"{name}: e_min {lim.e_min:.4f} ± {lim.e_min_sd:.4f}, e_max {lim.e_max:.4f} ± "
        f"{lim.e_max_sd:.4f} ({lim.measure} phi {lim.phi_max:.4f} to {lim.phi_min:.4f}; "
        f"{lim.packs} stream(s); densest: {_most(lim.e_min_from)}, loosest: "
        f"{_most(lim.e_max_from)})"
    )
    if args.json is not None:
        body = {
            "scene": name,
            "e_min": lim.e_min,
            "e_min_sd": lim.e_min_sd,
            "e_max": lim.e_max,
            "e_max_sd": lim.e_max_sd,
            "e_min_values": list(lim.e_min_values),
            "e_max_values": list(lim.e_max_values),
            "e_min_from": list(lim.e_min_from),
            "e_max_from": list(lim.e_max_from),
            "points": [
                {
                    "stream": k,
                    "mechanism": m,
                    "friction": mu,
                    # a material with a rolling model: the point's rolling friction mu_r
                    **(
                        {"rolling_friction": lim.rolling_frictions[i]}
                        if lim.rolling_frictions
                        else {}
                    ),
                    "phi": phi,
                }
                for i, (k, m, mu, phi) in enumerate(lim.points)
            ],
            "measure": lim.measure,
            "packs": lim.packs,
            "contact_model": model_record(scene.material),
        }
        atomic_write(args.json, json.dumps(body, indent=1).encode())
    return 0


def _what(row: dict) -> str:
    if row["mechanism"] == "servo":
        return "servo at zero friction"
    what = f"mu_dep {row['friction']:g}"
    return what + (f", mu_r {row['rolling_friction']:g}" if "rolling_friction" in row else "")


def _most(labels: tuple[str, ...]) -> str:
    """The label most streams share (the first of those in a tie)."""
    return max(dict.fromkeys(labels), key=labels.count)
