"""The CNN ring detector: model.py and train.py need torch; runtime.py needs only onnxruntime."""
