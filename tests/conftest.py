"""The real datasets ship inside the package (robocal/io/data), so tests on them always run.

Tests in other files still carry the ``shared_data`` marker; it is kept registered (it no
longer skips anything) so that pytest does not warn about an unknown marker.
"""


def pytest_configure(config):
    config.addinivalue_line("markers", "shared_data: uses the real datasets packaged in robocal/io/data")
