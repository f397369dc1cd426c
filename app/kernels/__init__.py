"""OpenCL kernels and their wrappers: the only package that imports pyopencl."""
