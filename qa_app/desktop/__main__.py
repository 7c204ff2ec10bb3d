import sys

from qa_app.desktop.app import main

sys.exit(main())
