"""dexwarp from Python: warp one dexterous-manipulation demonstration into many.

The same pipeline as the ``dexwarp`` command line (one Rust library), called in-process with
NumPy arrays in and out::

    import dexwarp
    demo = dexwarp.Demo.load("scenes/demos/mug.demo.json")
    config = dexwarp.Config.load("scenes/configs/mug_pass_wall.json")
    result = dexwarp.warp(demo, config, threshold_mm=5.0)
    result.report["metrics"]["d_c_mm"]["warped"], result.report["physics"]["verdict"]
    result.tau, result.object_positions, result.joints

Quaternions are ``[w, x, y, z]``, lengths metres, angles radians. Every input dexwarp refuses
raises :class:`DexwarpError` with the command line's message (file, field, what was
expected). The work runs with the GIL released.
"""

from dexwarp._dexwarp import (
    Config,
    Demo,
    DexwarpError,
    Result,
    __version__,
    augment,
    validate,
    warp,
)

__all__ = [
    "Config",
    "Demo",
    "DexwarpError",
    "Result",
    "__version__",
    "augment",
    "validate",
    "warp",
]
