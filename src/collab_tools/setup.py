from setuptools import find_packages, setup

package_name = 'collab_tools'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='Hetero-collab maintainers',
    maintainer_email='maintainers@hetero-collab.example.org',
    description='Orchestration, bag recording, run reports and a scripted driver.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            'bag_recorder = collab_tools.entry_points:bag_recorder',
            'bag_reindex = collab_tools.core.bag_repair:main',
            'live_view = collab_tools.entry_points:live_view',
            'scripted_driver = collab_tools.entry_points:scripted_driver',
            'visualiser = collab_tools.entry_points:visualiser',
        ],
    },
)
