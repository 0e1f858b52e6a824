"""Static scene description: declarative specs, builders, file format and compiled geometry."""

from fluids_bench.tasks.fluids.sim.layout.builders import (
    BUILDERS,
    build_layout,
    four_way,
    roundabout,
    t_junction,
)
from fluids_bench.tasks.fluids.sim.layout.compiled import (
    CAR,
    PEDESTRIAN,
    Layout,
    RouteTable,
    compile_layout,
)
from fluids_bench.tasks.fluids.sim.layout.io import (
    FORMAT_VERSION,
    layout_from_dict,
    layout_to_dict,
    load_layout,
    save_layout,
)
from fluids_bench.tasks.fluids.sim.layout.spec import (
    CarRoute,
    Crosswalk,
    Lane,
    LayoutSpec,
    Light,
    Sidewalk,
    Walk,
)

__all__ = [
    "BUILDERS",
    "CAR",
    "FORMAT_VERSION",
    "PEDESTRIAN",
    "CarRoute",
    "Crosswalk",
    "Lane",
    "Layout",
    "LayoutSpec",
    "Light",
    "RouteTable",
    "Sidewalk",
    "Walk",
    "build_layout",
    "compile_layout",
    "four_way",
    "layout_from_dict",
    "layout_to_dict",
    "load_layout",
    "roundabout",
    "save_layout",
    "t_junction",
]
