"""Images and files: the Image and its channels, EXR read/write, output planning and atomic writes."""
