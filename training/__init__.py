"""PyTorch reference models (VGRU-d, GRU-d), their training and their export to safetensors.

Run modules from the repository root: ``python -m training.<module>``.
"""
