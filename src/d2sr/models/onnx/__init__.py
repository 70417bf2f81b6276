"""ONNX work on trained models: export (with a parity check against torch), float16 weight storage and
int8 quantization. Inference on the files is ``d2sr.runtime.backends``."""
