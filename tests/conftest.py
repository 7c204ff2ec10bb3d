import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

# Widget logic runs on Qt's offscreen platform; the real 3D viewport needs an X display and runs
# in a second pytest process under Xvfb (tests/xvfb, see scripts/test.sh).
UNDER_XVFB = os.environ.get("QA_GUI_DISPLAY") == "xvfb"
if not UNDER_XVFB:
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    collect_ignore = ["xvfb"]
