"""Short differential fuzz of the Python and C parsers (the long run is
`navkit fuzz-proto --seconds 600`, or `make fuzz-long`)."""

import os
import random
import subprocess
import sys

from navkit.proto_fuzz import check_case


def test_python_and_c_parsers_agree_on_mutated_streams(prop_seed, prop_count):
    rng = random.Random(prop_seed)
    for case in range(prop_count * 3):
        problem = check_case(rng)
        assert problem is None, f"seed {prop_seed} case {case}: {problem}"


def test_fuzz_proto_names_a_missing_shim(tmp_path):
    """Without the C shim in the build folder: a clear error naming the file and how to
    build it, not a raw OSError."""
    env = {**os.environ, "NAVKIT_BUILD_DIR": str(tmp_path)}
    r = subprocess.run([sys.executable, "-m", "navkit", "fuzz-proto", "--count", "1"],
                       capture_output=True, text=True, env=env)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert f"{tmp_path}/tests/c/protocol/libnavkit_proto_shim.so is missing" in r.stderr
    assert "--target navkit_proto_shim" in r.stderr
