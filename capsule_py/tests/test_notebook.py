"""docs/notebooks/fig19.ipynb executed with nbclient on a 16 x 16 grid: every cell runs, the
figure is drawn, and the notebook's own checks of the paper's claims pass."""

import os

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")


def test_the_fig19_notebook_runs_and_draws(root, monkeypatch):
    path = root / "docs" / "notebooks" / "fig19.ipynb"
    nb = nbformat.read(path, as_version=4)
    monkeypatch.setenv("CAPSULE_FIG19_GRID", "16")
    client = nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                                     resources={"metadata": {"path": str(root)}})
    client.execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(images) == 1, "the figure was not drawn"
    text = "".join(o.get("text", "") for o in outputs)
    assert "3 maps of 16 x 16 initial states" in text and "period-1 share" in text
