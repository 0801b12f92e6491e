"""Results a person looks at: scored runs (summary.json), evaluate, figures, the
paper's tables and the static web leaderboard."""
