"""`fluids-bench render-layout`: a PNG preview of a layout (builder name or layout file).

Shows the drivable area, sidewalks, crosswalks, lane markings and terrain, every car route and
pedestrian walk, and the lights in their state at `--time`.

Example:

    fluids-bench render-layout four_way --lanes 2 --out four_way.png
    fluids-bench render-layout my_layout.json --out my_layout.png
"""

from __future__ import annotations

import argparse
import inspect
from pathlib import Path

from fluids_bench.commands import plain_text


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = subparsers.add_parser(
        "render-layout",
        help="preview a layout (builder name or layout JSON file) as a PNG",
        description=plain_text(__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "name",
        metavar="NAME",
        help="a builder (four_way, t_junction, roundabout) or a layout JSON file",
    )
    p.add_argument("--out", type=Path, default=None, help="PNG to write (default NAME.png here)")
    p.add_argument(
        "--lanes", type=int, default=None, help="lanes per direction (builders that take it)"
    )
    p.add_argument(
        "--no-lights", action="store_true", help="build without lights (builders that take it)"
    )
    p.add_argument("--size", type=int, default=640, help="image side in pixels (default 640)")
    p.add_argument("--time", type=float, default=0.0, help="show the lights as at this time (s)")
    p.set_defaults(func=run)


def load_spec(name: str, lanes: int | None = None, lights: bool = True):
    """The `LayoutSpec` named `name` (a builder) or stored at path `name`."""
    from fluids_bench.tasks.fluids.sim.layout.builders import BUILDERS

    options = {
        k: v for k, v in (("lanes", lanes), ("lights", None if lights else False)) if v is not None
    }
    if name in BUILDERS:
        accepted = inspect.signature(BUILDERS[name]).parameters
        for key in options:
            if key not in accepted:
                flag = "--lanes" if key == "lanes" else "--no-lights"
                raise ValueError(f"{flag} does not apply to layout '{name}'")
        return BUILDERS[name](**options)
    path = Path(name)
    if path.suffix.lower() == ".json" or path.exists():
        if options:
            raise ValueError("--lanes and --no-lights apply to builders only, not to layout files")
        from fluids_bench.tasks.fluids.sim.layout.io import load_layout

        return load_layout(path)
    raise ValueError(
        f"layout '{name}' is neither a builder ({', '.join(sorted(BUILDERS))}) nor a layout file"
    )


def run(args: argparse.Namespace) -> int:
    import cv2

    from fluids_bench.tasks.fluids.sim.layout.compiled import compile_layout
    from fluids_bench.tasks.fluids.sim.render import Renderer

    if not 64 <= args.size <= 4096:
        raise ValueError(f"--size is {args.size}; allowed: 64 to 4096 pixels")
    spec = load_spec(args.name, args.lanes, not args.no_lights)
    image = Renderer(compile_layout(spec), args.size).render_layout(args.time)
    out = args.out if args.out is not None else Path(f"{Path(args.name).stem}.png")
    out.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(out), cv2.cvtColor(image, cv2.COLOR_RGB2BGR)):
        raise FileNotFoundError(f"could not write {out}")
    print(f"wrote {out} ({spec.name}, {args.size}x{args.size})")
    return 0
