"""The engines' numba kernels: plain functions over arrays, apart from the Python drivers that call them."""
