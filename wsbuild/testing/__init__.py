"""`wsbuild test` and `wsbuild test-result`: what every test run shares, whatever runs the
tests: the run's request (`request`), the run (`test_run`), its packages' test closure
(`closure`), one package's tests with retries (`tester`), the cached result and its key (`cached_result`, `test_key`), the results
and summary (`results`), and `test-result`'s reading of a results tree (`junit`). How a
package's tests run is its build type's (build_types/test_runner.py).
May use: build_types, prefix, underlay, workspace, engine, events, errors.
"""
