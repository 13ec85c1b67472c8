"""Build a source notebook (no outputs) from a percent-format script: ``python tools/nbsource.py notebooks/py/NAME.py notebooks/NAME.ipynb``.

Cells are separated by lines starting with ``# %%``; ``# %% [markdown]`` starts a Markdown cell
(its lines' leading ``# `` is removed); ``# %% parameters`` starts the papermill parameters cell.
Kept so that notebooks can be edited as plain text and diffed; the .ipynb is what runs.
"""

import sys

import nbformat


def build(text: str):
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    cells, kind, buf = [], None, []

    def flush():
        if kind is None:
            return
        body = "\n".join(buf).strip("\n")
        if kind == "markdown":
            body = "\n".join(line[2:] if line.startswith("# ") else line.lstrip("#") for line in body.splitlines())
            cells.append(nbformat.v4.new_markdown_cell(body))
        else:
            cell = nbformat.v4.new_code_cell(body)
            if kind == "parameters":
                cell.metadata["tags"] = ["parameters"]
            cells.append(cell)

    for line in text.splitlines():
        if line.startswith("# %%"):
            flush()
            tag = line[4:].strip()
            kind = "markdown" if tag == "[markdown]" else ("parameters" if tag == "parameters" else "code")
            buf = []
        else:
            buf.append(line)
    flush()
    nb.cells = cells
    for i, c in enumerate(nb.cells):
        c["id"] = f"cell-{i}"
    return nb


if __name__ == "__main__":
    src, out = sys.argv[1], sys.argv[2]
    nbformat.write(build(open(src).read()), out)
