# swiftd.py CONF - runs one Swift server (account, container, object or proxy: the name of CONF,
# e.g. $S3_DIR/etc/proxy-server.conf) in the foreground, in one process (workers = 0). It is what
# /usr/bin/swift-*-server do (run_wsgi), plus what the test fixture needs; see start.sh and
# README.md. Adapted from the recipe in /work/shared/s3-swift (issue 29).
#
# - eventlet is patched before Swift is imported (with EVENTLET_NO_GREENDNS=yes in the
#   environment): otherwise it greens every existing RLock with a gc.collect() each, about 3 s
#   a process.
# - Swift reads swift.conf and writes the rings in the folder of CONF, not /etc/swift, and logs to
#   stderr (start.sh sends it to $S3_DIR/log/NAME.log), not to syslog.
# - No setsid(), no chdir('/'): Swift would leave start.sh's process group, the one stop.sh (and
#   the watchdog that runs it when the test process is gone) stops.
# - The proxy builds the three rings first (one device, one replica):
#   swift-ring-builder X.builder create 8 1 1; add r1z1-127.0.0.1:PORT/d1 100; rebalance.
import eventlet
eventlet.monkey_patch(all=False, socket=True, select=True, thread=True)
import configparser, logging, os, sys
from swift.common import utils, wsgi
utils.ThreadSafeSysLogHandler = lambda *a, **kw: logging.NullHandler()
wsgi.clean_up_daemon_hygiene = lambda: None
conf = sys.argv[1]
etc = os.path.dirname(conf)
utils.set_swift_dir(etc)
section = os.path.basename(conf)[:-len('.conf')]
kw = {}
if section == 'object-server':
    from swift.obj import server
    kw['global_conf_callback'] = server.global_conf_callback
if section == 'proxy-server':
    from swift.common.ring import RingBuilder
    for name in ('account', 'container', 'object'):
        cp = configparser.ConfigParser()
        cp.read('%s/%s-server.conf' % (etc, name))
        b = RingBuilder(8, 1, 1)
        b.add_dev({'id': 0, 'region': 1, 'zone': 1, 'ip': '127.0.0.1', 'device': 'd1',
                   'port': int(cp['DEFAULT']['bind_port']), 'weight': 100})
        b.rebalance()
        b.get_ring().save('%s/%s.ring.gz' % (etc, name))
sys.exit(wsgi.run_wsgi(conf, section, verbose=True, **kw))
