"""The report's navigation bar is made from its sections and lists every one of them."""

from __future__ import annotations

from html.parser import HTMLParser

from reports.render import SECTIONS, build_context, render


class _Outline(HTMLParser):
    """Collects the navigation links and every section's id and heading, in order."""

    def __init__(self) -> None:
        super().__init__()
        self.nav: list[tuple[str, str]] = []
        self.sections: list[tuple[str, str]] = []
        self._in_nav = self._in_h2 = False
        self._href = None
        self._text = ""

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "nav":
            self._in_nav = True
        elif tag == "a" and self._in_nav:
            self._href, self._text = a["href"], ""
        elif tag == "section":
            self.sections.append((a["id"], ""))
        elif tag == "h2" and self.sections:
            self._in_h2, self._text = True, ""

    def handle_endtag(self, tag):
        if tag == "nav":
            self._in_nav = False
        elif tag == "a" and self._href is not None:
            self.nav.append((self._href, self._text.strip()))
            self._href = None
        elif tag == "h2" and self._in_h2:
            self.sections[-1] = (self.sections[-1][0], self._text.strip())
            self._in_h2 = False

    def handle_data(self, data):
        if self._href is not None or self._in_h2:
            self._text += data


def test_navigation_lists_every_section_with_its_heading(tmp_path):
    html = render(build_context(tmp_path, tmp_path, tmp_path, ["bench", "report"],
                                tmp_path / "aep", tmp_path / "size"))
    outline = _Outline()
    outline.feed(html)
    # truth: the sections as the rendered page has them, not the list the code keeps
    numbered = [(sid, h) for sid, h in outline.sections if sid != "summary"]
    assert [f"#{sid}" for sid, _ in outline.sections] == [href for href, _ in outline.nav]
    assert len(numbered) == len(SECTIONS) >= 6
    for k, ((sid, heading), (href, label)) in enumerate(
            zip(numbered, [n for n in outline.nav if n[0] != "#summary"], strict=True), 1):
        # numbered 1, 2, ... in page order; the link's label is the heading's number and
        # its title up to any parenthesis
        assert heading.startswith(f"{k}. ")
        assert label == f"{k} {heading[len(f'{k}. '):].split(' (')[0]}"
        assert href == f"#{sid}"
    assert ("#energy", "5 Annual energy and drive sizing") in outline.nav
