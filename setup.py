"""Builds lamech's engine (issue 45): the C library in lamech/numeric/_engine/, compiled when
lamech is installed, as the extension module ``lamech.numeric._cengine_lib`` (loaded with
ctypes by :mod:`lamech.numeric._cengine`). Everything else is in pyproject.toml."""

from pathlib import Path

from setuptools import Extension, setup

here = Path(__file__).parent
folder = here / "lamech" / "numeric" / "_engine"
sources = sorted(str(p.relative_to(here)) for p in folder.glob("*.c"))
headers = sorted(str(p.relative_to(here)) for p in folder.glob("*.h"))

setup(
    ext_modules=[
        Extension(
            "lamech.numeric._cengine_lib",
            sources=sources,
            depends=headers,
            # the same numbers as the kernels run as Python: no fused multiply-add; no
            # -march=native (a cluster's machines share one installation)
            extra_compile_args=["-std=c99", "-O2", "-ffp-contract=off"],
            libraries=["m"],
        )
    ]
)
