"""numpydoc's docstring template, compiled once per build rather than once per docstring.

numpydoc renders every docstring through a Jinja template (``numpydoc_docstring.rst``), and
its ``get_doc_object`` builds a new template environment, and so reads and compiles that
template anew, at every docstring and signature: ~1000 times in this site's build, 2 of its
~27 CPU-s.  The template and the folders it is found in are the same at every call, so this
step builds it once per builder, exactly as numpydoc does, and hands numpydoc the compiled
template through the ``config["template"]`` its docstring classes read: the pages are the
same byte for byte.  Should a numpydoc release lay this out differently (no
``get_doc_object_orig``), numpydoc is left as it is.
"""

from __future__ import annotations

import os

from jinja2 import FileSystemLoader
from jinja2.sandbox import SandboxedEnvironment
from numpydoc import docscrape_sphinx
from numpydoc import numpydoc as numpydoc_extension
from sphinx.jinja2glue import BuiltinTemplateLoader

_TEMPLATE = "numpydoc_docstring.rst"


def _compiled_template(builder, templates: dict):
    """numpydoc's template as its ``get_doc_object`` loads it for ``builder`` (None: no
    builder, a plain file-system loader); compiled on the first call only."""
    if id(builder) not in templates:
        folders = [os.path.join(os.path.dirname(docscrape_sphinx.__file__), "templates")]
        if builder is None:
            loader = FileSystemLoader(folders)
        else:
            loader = BuiltinTemplateLoader()
            loader.init(builder, dirs=folders)
        template = SandboxedEnvironment(loader=loader).get_template(_TEMPLATE)
        templates[id(builder)] = (builder, template)  # the builder kept: its id stays its own
    return templates[id(builder)][1]


def setup(app):
    if not hasattr(docscrape_sphinx, "get_doc_object_orig"):
        return {"parallel_read_safe": True, "parallel_write_safe": True}
    templates: dict = {}  # id(builder) -> (builder, template)

    def get_doc_object(obj, what=None, doc=None, config=None, builder=None):
        config = {} if config is None else config
        config["template"] = _compiled_template(builder, templates)
        return docscrape_sphinx.get_doc_object_orig(
            obj,
            what=what,
            doc=doc,
            config=config,
            class_doc=docscrape_sphinx.SphinxClassDoc,
            func_doc=docscrape_sphinx.SphinxFunctionDoc,
            obj_doc=docscrape_sphinx.SphinxObjDoc,
        )

    # numpydoc's own hook for this: its setup(app, get_doc_object_=...) sets the same global
    numpydoc_extension.get_doc_object = get_doc_object
    return {"parallel_read_safe": True, "parallel_write_safe": True}
