"""Photometry: IES LM-63 and EULUMDAT files, luminous flux, BUG ratings, spectra and sensors."""
