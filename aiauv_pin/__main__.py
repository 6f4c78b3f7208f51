"""``python -m aiauv_pin``: the ``aiauv`` command line."""

from aiauv_pin.app.cli import console_main

if __name__ == "__main__":
    console_main()
