"""The weavefit.v1 wire contract: weavefit_pb2 and weavefit_pb2_grpc, generated
from proto/weavefit/v1/weavefit.proto when the package is built."""
