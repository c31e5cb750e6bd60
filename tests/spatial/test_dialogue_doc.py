"""The table of questions and answers in docs/dialogue.md is what ``ask`` says today."""

from __future__ import annotations

from pathlib import Path

from scenespeak.tools.dialogue_eval import DOC_QUESTIONS, update_doc_table

DOC = Path(__file__).resolve().parents[2] / "docs" / "dialogue.md"


def test_docs_table_is_current() -> None:
    text = DOC.read_text(encoding="utf-8")
    assert update_doc_table(text) == text, "regenerate the table (see docs/dialogue.md)"
    assert all(f"| {q} |" in text for q in DOC_QUESTIONS)
