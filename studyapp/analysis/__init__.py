"""The analysis of a study's answers (DESIGN §8): statistics, figures, report, model fits, simulated participants."""
