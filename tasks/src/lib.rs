//! The vertibench task set: 100 worlds x 10 start/goal pairs.
