"""Side-by-side benchmarks of wsbuild against colcon (see benchmarks/README.md)."""
