// Intentionally empty. The PROS entry points (initialize, autonomous, opcontrol, ...) live in
// pros_adapter.cpp, the one file that talks to PROS. This file exists so that applying PROS's
// kernel template (`pros conduct apply kernel`) keeps it instead of adding PROS's example
// src/main.cpp, whose entry points would clash with ours at link time.
