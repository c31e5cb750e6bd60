"""The fuzzing corpus and its runner (issue 12; see ``docs/trust.md``).

``python -m scenespeak.tools.fuzz run ROOT`` builds the corpus under ROOT and runs it;
``benchmarks/fuzz_corpus.py`` does the same with a summary table.
"""
