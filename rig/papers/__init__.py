"""The offline reproductions of the three papers, and each paper's constants."""
