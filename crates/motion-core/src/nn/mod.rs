//! Neural-network layers (Linear, GRU cells in both conventions, body GRU, LSTM, MLP).
