"""Perception on the Jetson: camera frames in, ring positions in the robot's frame out.

Each piece is usable alone (see README.md in this folder):

    sources/     camera sources behind one interface (RealSense, .bag, recordings, a socket stream)
    prefilter    the original team's HSV window + box-blurred mask, as an optional stage
    classical    a ring detector from the colour mask, contours and shape tests
    cnn/         a small CNN detector: training in PyTorch, inference with onnxruntime only
    localise     depth over the ring's own pixels, back-projection, camera mount -> robot frame
    calibrate    checkerboard calibration -> camera config
    pipeline     pre-filter + detector + localisation, the one call the daemon makes per frame

The inference path needs only numpy, OpenCV and onnxruntime: nothing here imports torch except
cnn/model.py and cnn/train.py, and nothing imports the simulator.
"""
