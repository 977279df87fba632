"""The ROS build, plan then execute: the run's frozen request (request.py), the plan of what
each package needs and why (plan.py, shown by plan_text.py), one package's job carried out
(execute.py: job.py, reuse.py, package.py) and the stages around them (pipeline.py). Its
rooms: the run's resources (resources/: compiler cache, distcc, the memory budget), a build
split across a CI matrix (shards/), and the suite's build-step oracle (oracles/). Runs on
engine/."""
