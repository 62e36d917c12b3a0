#!/usr/bin/env python3
"""Checks a stickslip report page (called by tests/reports/test_report.cpp).

Usage: check_report_html.py DIR/index.html

Fails (exit 1, reason on stderr) unless:
  - every non-void element is closed, in order (html.parser events, strict nesting);
  - every <img> embeds its plot as a data:image/svg+xml;base64 URI whose content is well-formed XML
    with an <svg> root, and names an existing copy of the plot in data-plot (relative to DIR);
  - every local link (href not starting with http, mailto or #) exists, and every #anchor exists.
Prints the number of plots on stdout.
"""
import base64
import html.parser
import os
import sys
import xml.dom.minidom

VOID = {"area", "base", "br", "col", "embed", "hr", "img", "input", "link", "meta", "source",
        "track", "wbr"}


class Checker(html.parser.HTMLParser):
    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.stack, self.errors, self.imgs, self.links, self.ids = [], [], [], [], set()

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if "id" in a:
            self.ids.add(a["id"])
        if tag == "img":
            self.imgs.append(a)
        if tag == "a" and "href" in a:
            self.links.append(a["href"])
        if tag not in VOID:
            self.stack.append((tag, self.getpos()))

    def handle_startendtag(self, tag, attrs):
        self.handle_starttag(tag, attrs)
        if tag not in VOID:
            self.stack.pop()

    def handle_endtag(self, tag):
        if tag in VOID:
            self.errors.append(f"end tag of void element </{tag}> at {self.getpos()}")
        elif not self.stack:
            self.errors.append(f"</{tag}> at {self.getpos()} closes nothing")
        elif self.stack[-1][0] != tag:
            self.errors.append(f"</{tag}> at {self.getpos()} closes <{self.stack[-1][0]}> "
                               f"opened at {self.stack[-1][1]}")
        else:
            self.stack.pop()


def main():
    path = sys.argv[1]
    base = os.path.dirname(path)
    with open(path, encoding="utf-8") as f:
        text = f.read()
    if not text.startswith("<!DOCTYPE html>"):
        print("no <!DOCTYPE html>", file=sys.stderr)
        return 1
    c = Checker()
    c.feed(text)
    c.close()
    errors = list(c.errors)
    errors += [f"<{t}> opened at {p} never closed" for t, p in c.stack]
    prefix = "data:image/svg+xml;base64,"
    for img in c.imgs:
        src = img.get("src", "")
        if not src.startswith(prefix):
            errors.append(f"img src is not an embedded SVG: {src[:60]}")
            continue
        try:
            svg = base64.b64decode(src[len(prefix):], validate=True)
            doc = xml.dom.minidom.parseString(svg)
            if doc.documentElement.tagName != "svg":
                errors.append(f"embedded plot root is <{doc.documentElement.tagName}>")
        except Exception as e:  # noqa: BLE001 - any decode/parse failure is a broken plot
            errors.append(f"embedded plot {img.get('data-plot')} does not decode/parse: {e}")
        plot = img.get("data-plot")
        if not plot or not os.path.isfile(os.path.join(base, plot)):
            errors.append(f"plot file {plot!r} referenced by an img does not exist")
        if not img.get("alt"):
            errors.append(f"img {plot} has no alt text")
    for href in c.links:
        if href.startswith(("http:", "https:", "mailto:")):
            continue
        if href.startswith("#"):
            if href[1:] not in c.ids:
                errors.append(f"link to missing anchor {href}")
        elif not os.path.exists(os.path.join(base, href)):
            errors.append(f"link to missing file {href}")
    if errors:
        print("\n".join(errors), file=sys.stderr)
        return 1
    print(len(c.imgs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
