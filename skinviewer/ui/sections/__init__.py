"""The sections of the settings panel (``ui/panel.py``). Each is a class made with
``(state, frame)`` that draws itself with ``draw(ui)`` under its own collapsing header, reads the
state and the frame controller, and changes them only through their methods."""
