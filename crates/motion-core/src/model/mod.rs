//! Motion predictors (VGRU-d, GRU-d), self-describing weights and closed-loop generation.
