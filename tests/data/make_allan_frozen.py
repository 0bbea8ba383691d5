"""Write ``allan_frozen.json``: a short record and its deviations from allantools, frozen,
so that the Allan tests need no optional package (run once, by hand; not a test).

    python tests/data/make_allan_frozen.py    # needs allantools (the bench extra)

The record (2048 fractional-frequency samples, tau0 = 1 s: white noise plus a random
walk, so that the deviations have some shape) is stored with the results, to the
digits ``repr`` gives, so the test reads the same numbers whatever numpy's generators
do. allantools computes the overlapping Allan (``oadev``), non-overlapping Allan
(``adev``), modified Allan (``mdev``) and total (``totdev``) deviations of it as
frequency data at the averaging factors ``M``.
"""

import json
from pathlib import Path

import allantools
import numpy as np

M = [1, 2, 3, 4, 8, 16, 32, 64, 128, 256, 512]


def main():
    rng = np.random.default_rng(20260101)
    y = rng.standard_normal(2048) + np.cumsum(0.05 * rng.standard_normal(2048))
    y = [float(v) for v in y]
    out = {
        "source": f"allantools {allantools.__version__}, data_type freq, rate 1.0",
        "script": "tests/data/make_allan_frozen.py",
        "m": M,
        "y": y,
    }
    for name in ("oadev", "adev", "mdev", "totdev"):
        taus, dev, _, n = getattr(allantools, name)(
            np.array(y), rate=1.0, data_type="freq", taus=np.array(M, float)
        )
        assert list(taus) == [float(m) for m in M], (name, taus)
        out[name] = [float(v) for v in dev]
        out[f"{name}_n"] = [int(v) for v in n]
    path = Path(__file__).with_name("allan_frozen.json")
    path.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
