"""What build and test steps read, observed while they run: the interposed C library
(interposer.c, built at first use), the hook of their Python processes (pyhook/), the
environment a step starts from, and the reading of what they wrote down (log.py). No ROS
inside."""
