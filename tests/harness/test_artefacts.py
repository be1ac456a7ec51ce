"""Trajectory files: the table is the one pandas' conversion makes of the augmented frame, and reads back."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from gna.trajectory import COLUMNS
from harness.artefacts import augmented, read_trajectory, trajectory_table, units_of, write_trajectory


def _trajectory(n: int = 40) -> pd.DataFrame:
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 3.9, n)
    df = pd.DataFrame(rng.normal(size=(n, len(COLUMNS))) * 0.2, columns=list(COLUMNS), index=pd.Index(t, name="t"))
    df["V"] = 60.0 + df["V"]
    df["z"] = -500.0 + df["z"]
    df.iloc[5, 0] = np.nan  # a diverged sample: null in the file, NaN read back
    df.iloc[6, 1] = np.inf
    return df


def _by_pandas(df: pd.DataFrame, metadata: dict) -> pa.Table:
    """The table :meth:`pyarrow.Table.from_pandas` makes of the augmented frame, built here independently of
    :func:`harness.artefacts.trajectory_table` (its units and metadata)."""
    flat = augmented(df).reset_index()
    flat = flat.rename(columns={flat.columns[0]: "t"})
    units = units_of(flat.columns)
    fields = [
        pa.field(str(c), pa.float64() if flat[c].dtype.kind in "fiu" else pa.string(), metadata={"unit": units[c]})
        for c in flat.columns
    ]
    meta = {"gflat.units": json.dumps(units), "gflat": json.dumps(metadata)}
    return pa.Table.from_pandas(flat, schema=pa.schema(fields, metadata=meta), preserve_index=False)


@pytest.mark.parametrize(
    "change",
    [
        lambda df: df,
        lambda df: df.rename_axis(None),  # an unnamed index: still the column t
        lambda df: df.iloc[:0],  # empty: no added column
        lambda df: df[["x", "y", "V"]],  # without the states the added columns need
        lambda df: df.assign(label="a"),  # a text column: through pandas' conversion
        lambda df: df.assign(n=1),  # an integer column: the same
    ],
)
def test_table_is_pandas_conversion_of_the_augmented_frame(change):
    df = change(_trajectory())
    meta = {"status": "completed", "t_end": 3.9}
    got = trajectory_table(augmented(df), meta)
    want = _by_pandas(df, meta)
    assert got.equals(want, check_metadata=True)
    assert got.schema.metadata[b"pandas"] == want.schema.metadata[b"pandas"]


def test_written_file_reads_back_the_augmented_frame(tmp_path):
    df = _trajectory()
    (path,) = write_trajectory(tmp_path, "trajectory-inhouse", df, metadata={"status": "completed"})
    back, units = read_trajectory(path)
    full = augmented(df)
    assert list(back.columns) == list(full.columns) and back.index.name == "t"
    np.testing.assert_array_equal(back.to_numpy(), full.to_numpy())  # NaN and inf kept, bit for bit
    np.testing.assert_array_equal(back.index.to_numpy(), df.index.to_numpy())
    assert units["h"] == "m" and units["Mach"] == "-" and units["t"] == "s"
    assert pd.read_parquet(path).equals(full.reset_index())  # pandas' own reader, from its metadata
    column = pq.ParquetFile(path).metadata.row_group(0).column(1)
    assert "RLE_DICTIONARY" not in column.encodings and column.compression == "SNAPPY"
