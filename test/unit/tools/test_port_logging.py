"""A core's log lines reach the node's logger with one call site per severity, throttled per kind."""
from collab_tools.port_logging import PortLogger


class RecordingLogger:
    def __init__(self):
        self.lines = []

    def info(self, text):
        self.lines.append(('info', text))

    def warning(self, text):
        self.lines.append(('warning', text))

    def error(self, text):
        self.lines.append(('error', text))


def test_levels_map_to_the_loggers_severities():
    logger = RecordingLogger()
    log = PortLogger(logger).log
    for level in ('info', 'warn', 'warning', 'error'):
        log(level, level)
    assert logger.lines == [('info', 'info'), ('warning', 'warn'), ('warning', 'warning'), ('error', 'error')]


def test_throttling_is_per_message_kind_not_per_call_site():
    logger = RecordingLogger()
    log = PortLogger(logger).log
    log('warn', 'robot 1 stuck for 2.0 s', throttle=60.0)
    log('warn', 'robot 1 stuck for 3.5 s', throttle=60.0)   # same kind (numbers aside): throttled
    log('warn', 'camera frame late', throttle=60.0)         # another kind: logged
    log('warn', 'robot 1 stuck for 4.0 s')                   # unthrottled call: always logged
    assert [text for _, text in logger.lines] == ['robot 1 stuck for 2.0 s', 'camera frame late',
                                                  'robot 1 stuck for 4.0 s']
