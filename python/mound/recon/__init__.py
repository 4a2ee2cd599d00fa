"""The 3-D stage on the Python side: figures of mound_recon's outputs (the reconstruction
itself is C++, build/mound_recon, run through mound.native)."""
