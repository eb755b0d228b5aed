"""The bottom layer: errors a user can cause and the options registry. Imports nothing of rtlab."""
