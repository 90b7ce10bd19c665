from setuptools import find_packages, setup

package_name = 'pybullet_bridge'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        # Report plug-in for scripts/report (see collab_tools.report_cli).
        ('share/ament_index/resource_index/collab_report_plots',
         ['resource/collab_report_plots/' + package_name]),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='Hetero-collab maintainers',
    maintainer_email='maintainers@hetero-collab.example.org',
    description='pybullet simulation bridge: robots, sensors and the top-view camera.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'pybullet_bridge = pybullet_bridge.entry_points:pybullet_bridge',
        ],
    },
)
