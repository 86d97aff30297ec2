import h5py
import numpy as np
import pytest

from score4.output import atomic_h5


def test_interrupted_writer_leaves_nothing_and_keeps_the_old_file(tmp_path):
    out = tmp_path / "r.h5"
    with atomic_h5(out) as f:
        f["x"] = np.arange(3)

    def interrupted_write():
        with atomic_h5(out) as f:
            f["x"] = np.arange(10)
            raise KeyboardInterrupt  # e.g. Ctrl-C half-way through writing

    with pytest.raises(KeyboardInterrupt):
        interrupted_write()
    with h5py.File(out, "r") as f:
        assert f["x"][()].tolist() == [0, 1, 2]
    assert [p.name for p in tmp_path.iterdir()] == ["r.h5"]
