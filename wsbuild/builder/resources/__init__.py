"""What a build run holds beside its plan, opened once for the run and shared by its package
builds: the compiler cache (compiler_cache.py), compiling on other machines (distcc.py) and the
memory budget that, with the CPUs, decides every job that starts (memory.py). Nothing here
imports the rest of builder/."""
