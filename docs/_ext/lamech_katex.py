"""Math in the HTML docs rendered by the KaTeX that lamech vendors for its report pages.

Sphinx's own ``sphinx.ext.mathjax`` loads MathJax from a CDN, so offline the docs showed
raw LaTeX. ``sphinxcontrib-katex`` would add a dependency that, by default, also fetches
KaTeX from a CDN. This renderer writes each formula into a ``span``/``div`` of class
``math`` (as the MathJax one does) and a few lines of script render them in the browser
with ``lamech/present/vendor/katex``, copied into the build's ``_static/katex``.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from docutils import nodes
from sphinx.util.math import get_node_equation_number

import lamech

# The package's copy, wherever the docs are built from (the tests build a copy of docs/).
VENDOR = Path(lamech.__file__).resolve().parent / "present" / "vendor" / "katex"

# Renders every element the visitors below wrote; an equation KaTeX cannot parse is shown
# as its LaTeX source (throwOnError false) rather than breaking the rest of the page.
RENDER = """
document.addEventListener("DOMContentLoaded", function () {
  document.querySelectorAll(".math[data-tex]").forEach(function (el) {
    katex.render(el.getAttribute("data-tex"), el.querySelector(".tex") || el, {
      displayMode: el.tagName === "DIV", throwOnError: false, strict: "ignore"
    });
  });
});
"""


def _visit_math(self, node: nodes.math) -> None:
    tex = node.astext()
    self.body.append(
        self.starttag(node, "span", "", CLASS="math notranslate nohighlight", **{"data-tex": tex})
    )
    self.body.append(self.encode(tex) + "</span>")
    raise nodes.SkipNode


def _display_tex(node: nodes.math_block) -> str:
    """The LaTeX of a display block: several equations (blank-line separated) aligned."""
    parts = [p for p in node.astext().split("\n\n") if p.strip()]
    parts = [r"\begin{split}" + p + r"\end{split}" if r"\\" in p else p for p in parts]
    if len(parts) > 1:
        return r"\begin{aligned}" + r"\\".join(parts) + r"\end{aligned}"
    return parts[0] if parts else ""


def _visit_displaymath(self, node: nodes.math_block) -> None:
    tex = _display_tex(node)
    self.body.append(
        self.starttag(node, "div", CLASS="math notranslate nohighlight", **{"data-tex": tex})
    )
    if node["number"]:
        number = get_node_equation_number(self, node)
        self.body.append(f'<span class="eqno">({number})')
        self.add_permalink_ref(node, "Link to this equation")
        self.body.append("</span>")
    self.body.append('<span class="tex">' + self.encode(tex) + "</span></div>\n")
    raise nodes.SkipNode


def _install(app, pagename, templatename, context, doctree) -> None:
    if app.builder.format != "html" or not context.get("has_maths_elements"):
        return
    app.builder.add_css_file("katex/katex.min.css")
    app.builder.add_js_file("katex/katex.min.js")
    app.builder.add_js_file(None, body=RENDER)


def _copy_vendor(app, exception) -> None:
    if exception is None and app.builder.format == "html":
        shutil.copytree(VENDOR, Path(app.outdir) / "_static" / "katex", dirs_exist_ok=True)


def setup(app):
    app.add_html_math_renderer(
        "katex", inline_renderers=(_visit_math, None), block_renderers=(_visit_displaymath, None)
    )
    app.connect("html-page-context", _install)
    app.connect("build-finished", _copy_vendor)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
