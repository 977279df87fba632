"""The execution engine, with no ROS knowledge: jobs and their results, the ready queue and
the scheduler, child process groups, the workspace lock, run logs, timings and the jobserver."""
