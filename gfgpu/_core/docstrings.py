"""Docstring texts written once: ``%(name)s`` placeholders filled from one dict (scipy's docfiller).

scipy.ndimage writes the parameter texts its filters share once (``_ni_docstrings.docdict``)
and fills them into each docstring with a decorator (``docfiller``).  :func:`docfiller` does the
same here: a placeholder ``%(name)s`` alone on its line is replaced by the text ``name``, every
line of it indented as the placeholder was, so numpydoc sections stay intact whatever the
docstring's indentation.  Nothing else in the docstring is touched (a ``%`` elsewhere needs no
escaping), and a placeholder without a text is an error when the module is imported.

Examples
--------
>>> fill = docfiller({"x": '''
...     x : dask.array.Array
...         The input, in any chunking.'''})
>>> @fill
... def f(x):
...     \"\"\"Do it.
...
...     Parameters
...     ----------
...     %(x)s
...     \"\"\"
>>> import inspect
>>> print(inspect.cleandoc(f.__doc__))
Do it.
<BLANKLINE>
Parameters
----------
x : dask.array.Array
    The input, in any chunking.
"""

from __future__ import annotations

import re
import textwrap

__all__ = ["fill_doc", "docfiller"]

_PLACEHOLDER = re.compile(r"^(?P<indent>[ \t]*)%\((?P<name>\w+)\)s[ \t]*$", re.MULTILINE)


def fill_doc(doc, texts):
    """``doc`` with every line that holds only ``%(name)s`` replaced by ``texts[name]``.

    Each text is dedented, stripped of its surrounding blank lines and indented as its
    placeholder; blank lines inside a text stay blank (no trailing spaces).

    Raises
    ------
    KeyError
        A placeholder whose name is not in ``texts`` (the message lists the names known).
    """
    def one(match):
        name, indent = match.group("name"), match.group("indent")
        if name not in texts:
            raise KeyError(f"docstring placeholder %({name})s has no text; the texts are "
                           f"{', '.join(sorted(texts))}")
        lines = textwrap.dedent(texts[name]).strip("\n").splitlines()
        return "\n".join(indent + line if line.strip() else "" for line in lines)

    return _PLACEHOLDER.sub(one, doc)


def docfiller(texts):
    """A decorator that fills the ``%(name)s`` placeholders of a function's docstring from ``texts``.

    The returned decorator keeps the texts as its ``texts`` attribute (a copy).  A function
    without a docstring (``python -OO``) is returned as it is.
    """
    texts = dict(texts)

    def decorate(function):
        if function.__doc__:
            function.__doc__ = fill_doc(function.__doc__, texts)
        return function

    decorate.texts = texts
    return decorate
