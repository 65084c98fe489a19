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
