"""Short differential fuzz of the Python and C parsers (the long run is
`navkit fuzz-proto --seconds 600`, or `make fuzz-long`)."""

import random

from navkit.proto_fuzz import check_case


def test_python_and_c_parsers_agree_on_mutated_streams(prop_seed, prop_count):
    rng = random.Random(prop_seed)
    for case in range(prop_count * 3):
        problem = check_case(rng)
        assert problem is None, f"seed {prop_seed} case {case}: {problem}"
