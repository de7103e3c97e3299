"""Execute analysis.ipynb headless (nbclient): writes analysis.executed.ipynb and the PNGs in
experiments/figures/. `make notebook` runs this; open the notebook in Jupyter to explore."""

from pathlib import Path

import nbclient
import nbformat

HERE = Path(__file__).resolve().parent


def main() -> None:
    notebook = nbformat.read(HERE / "analysis.ipynb", as_version=4)
    nbclient.NotebookClient(
        notebook, timeout=300, resources={"metadata": {"path": str(HERE)}}
    ).execute()
    out = HERE / "analysis.executed.ipynb"
    nbformat.write(notebook, out)
    print(f"wrote {out} and {HERE / 'figures'}/*.png")


if __name__ == "__main__":
    main()
