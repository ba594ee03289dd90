# Shared set-up of the Python module's tests (tests/python/): the CLI binary
# (BRDFTAB_CLI, set by CTest) and small tables generated with it once per
# session.  Run through CTest: `ctest --test-dir build -L python`.
import os
import subprocess
import textwrap

import pytest

import brdftab  # noqa: F401  (fail early with the import error)


def _cli():
    path = os.environ.get("BRDFTAB_CLI")
    if not path or not os.path.exists(path):
        pytest.exit("BRDFTAB_CLI must name the brdftab binary (set by CTest)", returncode=2)
    return path


class Tables:
    """Generates small tables with the CLI into a session directory."""

    def __init__(self, directory):
        self.directory = directory
        self.cli = _cli()
        self._made = {}

    def run(self, *args, check=True):
        return subprocess.run([self.cli, *map(str, args)], capture_output=True, text=True,
                              check=check)

    def generate(self, name, spec):
        """The path of <name>.h5 generated from the TOML text `spec`."""
        if name not in self._made:
            spec_path = self.directory / f"{name}.toml"
            spec_path.write_text(textwrap.dedent(spec))
            out = self.directory / f"{name}.h5"
            r = self.run("generate", spec_path, "-o", out, "--seed", 3, check=False)
            if r.returncode != 0:
                raise RuntimeError(f"brdftab generate {name} failed:\n{r.stderr}")
            self._made[name] = str(out)
        return self._made[name]


@pytest.fixture(scope="session")
def tables(tmp_path_factory):
    return Tables(tmp_path_factory.mktemp("tables"))


# Specs used by several tests.  Small grids: the tests check the module
# against the CLI and the sampler against itself, not the models.

# Oren-Nayar, the direct term per unit rho, the two-bounce term per unit
# rho^2, and their recombination at any rho (quadrature; a second).  theta_i
# stops at 80: where both directions graze the direct term grows like
# 1/cos theta (docs/models/oren-nayar.md); theta_o reaches 90 for sampling.
OREN_NAYAR = """
    model = "oren-nayar"
    [parameters]
    nodes = 6
    [[axes]]
    name = "theta_i"
    range = [0.0, 80.0]
    count = 7
    [[axes]]
    name = "theta_o"
    range = [0.0, 90.0]
    count = 7
    spacing = "cos"
    [[axes]]
    name = "phi_d"
    range = [0.0, 180.0]
    count = 7
    [[axes]]
    name = "sigma"
    range = [0.0, 40.0]
    count = 3
    [[tables]]
    quantity = "brdf_direct"
    [[tables]]
    quantity = "brdf_interreflection"
    [[recombined]]
    name = "brdf"
    parameter = "rho"
    range = [0.0, 1.0]
    [[recombined.terms]]
    table = "brdf_direct"
    coeffs = [0.0, 1.0]
    [[recombined.terms]]
    table = "brdf_interreflection"
    coeffs = [0.0, 0.0, 1.0]
    [integration]
    method = "quadrature"
    [output]
    type = "float64"
"""

# Rough dielectric (closed form) over mu_i, theta_o across the horizon and a
# log-spaced alpha: reflection and transmission in one table.
ROUGH_DIELECTRIC = """
    model = "rough-dielectric"
    [parameters]
    distribution = "ggx"
    eta = 1.5
    [[axes]]
    name = "mu_i"
    range = [0.0, 1.0]
    count = 6
    [[axes]]
    name = "theta_o"
    range = [0.0, 180.0]
    count = 13
    [[axes]]
    name = "phi_d"
    range = [0.0, 180.0]
    count = 7
    [[axes]]
    name = "alpha"
    range = [0.2, 0.8]
    count = 3
    spacing = "log"
    [[tables]]
    name = "bsdf"
    quantity = "bsdf"
    [output]
    type = "float64"
"""
