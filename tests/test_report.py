"""ringsim.report.replace_section: scripts sharing one Markdown file keep each other's sections."""

from ringsim.report import replace_section


def test_replace_append_and_create(tmp_path):
    doc = tmp_path / "docs" / "perf.md"
    replace_section(doc, "## A", "## A\n\none\n", "Performance")
    assert doc.read_text() == "# Performance\n\n## A\n\none\n"
    replace_section(doc, "## B", "## B\n\ntwo\n", "Performance")
    replace_section(doc, "## A", "## A\n\nthree\n", "Performance")
    assert doc.read_text() == "# Performance\n\n## A\n\nthree\n\n## B\n\ntwo\n"
    replace_section(doc, "## B", "## B\n\nfour\n", "Performance")
    assert doc.read_text() == "# Performance\n\n## A\n\nthree\n\n## B\n\nfour\n"


def test_a_heading_that_starts_another_is_not_that_section(tmp_path):
    """``## The presets`` does not replace ``## The presets in their equilibrium`` (nor the
    other way round): a heading is matched as a whole line."""
    doc = tmp_path / "perf.md"
    doc.write_text("# Performance\n\n## The presets in their equilibrium: prose\n\nkept\n")
    replace_section(doc, "## The presets in their equilibrium",
                    "## The presets in their equilibrium\n\ntable\n", "Performance")
    text = doc.read_text()
    assert "kept" in text and text.count("## ") == 2
    replace_section(doc, "## The presets in their equilibrium",
                    "## The presets in their equilibrium\n\nnew table\n", "Performance")
    text = doc.read_text()
    assert "kept" in text and "new table" in text and "\ntable" not in text


def test_the_hand_written_rest_after_the_marker_is_kept(tmp_path):
    """A section whose script-written part ends with a `KEPT_MARKER` line keeps its
    hand-written rest (its ### subsections) when the script writes it again."""
    from ringsim.report import KEPT_MARKER

    doc = tmp_path / "perf.md"
    mark = f"{KEPT_MARKER}x.py writes; the text below is kept -->"
    doc.write_text(f"# P\n\n## G\n\nold table\n\n{mark}\n\n### Sub\n\nprose\n\n## H\n\nh\n")
    replace_section(doc, "## G", f"## G\n\nnew table\n\n{mark}\n", "P")
    assert doc.read_text() == (f"# P\n\n## G\n\nnew table\n\n{mark}\n\n### Sub\n\nprose\n\n"
                               "## H\n\nh\n")
