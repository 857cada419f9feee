//! Local parallel evaluation of a planner on the task set: results, summaries, charts, comparisons.
