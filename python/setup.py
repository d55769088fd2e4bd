"""Build step of the weavefit package: the weavefit.v1 stubs, generated.

pyproject.toml holds the metadata; this only makes build_py run
grpc_tools.protoc on ../proto/weavefit/v1/weavefit.proto (the checkout's
proto, beside this folder) into the build tree, so that the wheel carries
weavefit/v1/weavefit_pb2.py and weavefit_pb2_grpc.py and the source tree
never does. An sdist is not supported: it would not carry the proto.
"""
import os

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = os.path.dirname(os.path.abspath(__file__))
PROTO_ROOT = os.path.normpath(os.path.join(HERE, os.pardir, "proto"))
PROTO = os.path.join(PROTO_ROOT, "weavefit", "v1", "weavefit.proto")


class BuildPyWithStubs(build_py):
    """build_py, then the weavefit.v1 stubs generated into build_lib."""

    def run(self) -> None:
        super().run()
        if not os.path.isfile(PROTO):
            raise SystemExit(f"weavefit: no {PROTO}: build the package from a weavefit "
                             "checkout (python/ beside proto/)")
        try:
            from grpc_tools import protoc
        except ImportError:
            raise SystemExit("weavefit: the build needs grpc_tools (Debian: python3-grpc-tools)")
        out = os.path.abspath(self.build_lib)
        self.mkpath(os.path.join(out, "weavefit", "v1"))
        args = ["grpc_tools.protoc", "-I" + PROTO_ROOT, "--python_out=" + out,
                "--grpc_python_out=" + out, PROTO]
        self.announce("generating the weavefit.v1 stubs: " + " ".join(args[1:]), level=2)
        if protoc.main(args) != 0:
            raise SystemExit("weavefit: grpc_tools.protoc failed on " + PROTO)


setup(cmdclass={"build_py": BuildPyWithStubs})
